// Page-cache eviction and residency (PageCache.h).
#include "pbdam/streaming/PageCache.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "pbdam/formats/Manifest.h"
#include "pbdam/streaming/MappedFile.h"

using namespace pbdam::formats;

namespace pbdam::streaming {

Result<void> evictFromPageCache(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    return makeError(ErrorCode::IoError,
                     path.string() + ": cannot open (" + std::strerror(errno) + ")");
  }
  // Dirty pages cannot be dropped: write them back first (datasets are written with fsync, so
  // this is normally a no-op).
  ::fdatasync(fd);
  const int rc = ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
  ::close(fd);
  if (rc != 0) {
    return makeError(ErrorCode::IoError, path.string() + ": posix_fadvise(DONTNEED) failed (" +
                                             std::strerror(rc) + ")");
  }
  return {};
}

Result<PageResidency> pageResidency(const std::filesystem::path& path) {
  auto file = MappedFile::open(path);
  if (!file) return std::move(file).error();
  auto pages = file->residentPages(0, file->size());
  if (!pages) return std::move(pages).error();
  return PageResidency{pages->first, pages->second};
}

Result<std::vector<std::filesystem::path>> datasetFiles(const std::filesystem::path& directory) {
  auto manifest = readManifest(directory);
  if (!manifest) return std::move(manifest).error();
  std::vector<std::filesystem::path> files{directory / kManifestFileName};
  for (const ManifestFace& f : manifest->faces) files.push_back(directory / f.file);
  return files;
}

Result<PageResidency> evictDataset(const std::filesystem::path& directory) {
  auto files = datasetFiles(directory);
  if (!files) return std::move(files).error();
  for (const auto& f : *files) {
    if (auto r = evictFromPageCache(f); !r) return r.error();
  }
  PageResidency total;
  for (const auto& f : *files) {
    auto r = pageResidency(f);
    if (!r) return std::move(r).error();
    total.residentPages += r->residentPages;
    total.totalPages += r->totalPages;
  }
  return total;
}

}  // namespace pbdam::streaming
