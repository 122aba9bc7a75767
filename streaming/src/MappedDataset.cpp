// Mapping a dataset directory (MappedDataset.h).
#include "pbdam/streaming/MappedDataset.h"

#include "pbdam/formats/Checksum.h"

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
  if (manifest->voids) {
    const std::filesystem::path path = directory / manifest->voids->file;
    auto file = MappedFile::open(path);
    if (!file) return std::move(file).error();
    const std::span<const std::byte> voidBytes = file->bytes();
    if (voidBytes.size() != manifest->voids->bytes || crc32(voidBytes) != manifest->voids->crc32) {
      return makeError(ErrorCode::CorruptData,
                       path.string() + ": does not match its manifest entry (size or CRC-32)");
    }
    auto voids = decodeVoidMap(voidBytes, path.string());
    if (!voids) return std::move(voids).error();
    if (voids->surfaces.size() != manifest->insets.size()) {
      return makeError(ErrorCode::CorruptData, path.string() + ": lists " +
                                                   std::to_string(voids->surfaces.size()) +
                                                   " inset surfaces, the manifest " +
                                                   std::to_string(manifest->insets.size()));
    }
    dataset->voids_ = std::move(voids).value();
  }
  return dataset;
}

std::optional<MappedDataset::VoidAt> MappedDataset::voidAt(double lat, double lon) const noexcept {
  // The finest first: where insets overlap, the finer one's heights are drawn.
  std::optional<VoidAt> found;
  double finest = 0.0;
  for (std::size_t i = 0; i < voids_.surfaces.size(); ++i) {
    const VoidGrid& g = voids_.surfaces[i];
    const std::optional<VoidKind> kind = g.at(lat, lon);
    if (kind && (!found || g.latSpacingDegrees < finest)) {
      found = VoidAt{i, *kind};
      finest = g.latSpacingDegrees;
    }
  }
  return found;
}

std::uint64_t MappedDataset::bytes() const noexcept {
  std::uint64_t total = 0;
  for (const MappedFile& f : files_) total += f.size();
  return total;
}

}  // namespace pbdam::streaming
