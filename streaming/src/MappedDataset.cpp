// Mapping a dataset directory (MappedDataset.h).
#include "pbdam/streaming/MappedDataset.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::streaming {

Result<std::unique_ptr<MappedDataset>> MappedDataset::open(const std::filesystem::path& directory,
                                                           const FaceViewOptions& faceOptions) {
  std::error_code ec;
  if (!std::filesystem::is_directory(directory, ec)) {
    return makeError(ErrorCode::NotFound, directory.string() + ": not a dataset directory");
  }
  auto manifest = readManifest(directory);
  if (!manifest) return std::move(manifest).error();
  std::unique_ptr<MappedDataset> dataset(new MappedDataset());
  dataset->directory_ = directory;
  std::array<std::span<const std::byte>, 6> bytes;
  for (std::size_t f = 0; f < 6; ++f) {
    auto file = MappedFile::open(directory / manifest->faces[f].file);
    if (!file) return std::move(file).error();
    if (auto advised = file->advise(MappingAdvice::Random); !advised) {
      return advised.error();
    }
    bytes[f] = file->bytes();
    dataset->files_[f] = std::move(file).value();
  }
  auto view = DatasetView::open(*manifest, bytes, directory.string(), faceOptions);
  if (!view) return std::move(view).error();
  dataset->view_ = std::move(view).value();
  return dataset;
}

std::uint64_t MappedDataset::bytes() const noexcept {
  std::uint64_t total = 0;
  for (const MappedFile& f : files_) total += f.size();
  return total;
}

}  // namespace pbdam::streaming
