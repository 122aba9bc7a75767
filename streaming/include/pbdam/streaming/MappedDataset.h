// A dataset directory mapped read-only: manifest.json read and checked, the six face files
// mmapped (MADV_RANDOM, so a fault reads its page and not megabytes around it: docs/architecture.md
// "Measured facts"), and a validated DatasetView over the mappings. Everything on the render path
// reads the face files through these mappings, never with read(). Thread-safety: read-only after
// open; the object must outlive every view, span and record taken from it.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <optional>

#include "pbdam/formats/Result.h"
#include "pbdam/formats/VoidMap.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/streaming/MappedFile.h"

/// The streaming layer: datasets mapped from disk, the page cache and its locks, prefetching and
/// decoding ahead of the camera, no-stall loading, and the memory budget that sizes them.
namespace pbdam::streaming {

/// A dataset directory mapped read-only: its manifest read and checked, the six face files
/// mapped (MADV_RANDOM), the void map read, and a validated runtime::DatasetView over the
/// mappings. Read-only after open; it must outlive every view, span and record taken from it.
class MappedDataset final {
 public:
  /// Opens DIR: NotFound when DIR has no manifest.json (an incomplete or missing dataset),
  /// CorruptData naming the file when a face (or the void map) does not match its manifest
  /// entry. `faceOptions`:
  /// node tables held whole (the default) or paged (DatasetView::open).
  static formats::Result<std::unique_ptr<MappedDataset>> open(
      const std::filesystem::path& directory, const formats::FaceViewOptions& faceOptions = {});

  /// The dataset as the runtime reads it, over the mappings.
  const runtime::DatasetView& view() const noexcept { return view_; }
  /// The mapping of face file `face` (0..5).
  const MappedFile& faceFile(int face) const noexcept {
    return files_[static_cast<std::size_t>(face)];
  }
  /// The dataset's directory, as open() was given it.
  const std::filesystem::path& directory() const noexcept { return directory_; }
  /// Total bytes of the six face files.
  std::uint64_t bytes() const noexcept;

  /// A void of an inset at a point: the manifest's inset index and what the void became.
  struct VoidAt final {
    std::size_t inset = 0;  ///< index into the manifest's insets
    formats::VoidKind kind = formats::VoidKind::FilledFromRim;  ///< what the void became
  };
  /// Whether (lat, lon) lies in a void of an inset (the sample nearest it was a void's), the
  /// finest inset first; nullopt in a dataset without voids (voids.bin, read and checked at
  /// open).
  std::optional<VoidAt> voidAt(double latDegrees, double lonDegrees) const noexcept;

 private:
  MappedDataset() = default;
  std::filesystem::path directory_;
  std::array<MappedFile, 6> files_;
  runtime::DatasetView view_;
  formats::VoidMap voids_;
};

}  // namespace pbdam::streaming
