// DecodeScheduler: decodes the patches and tiles a pass misses in the GPU cache
// (docs/architecture.md "Streaming"; [P-BDAM 2003] §4.4) in parallel on TBB workers, straight into
// host memory the caller provides (the GPU cache's staging buffer), in the layout the GPU pools
// copy from. No Vulkan here. Thread-safety: const members only; decode() may run on several threads
// at once for disjoint outputs.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "pbdam/formats/Result.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/streaming/ResidencyLru.h"

namespace pbdam::streaming {

/// One vertex as the patch pools hold it (gpu/PatchPipeline.h binds it): b1, b2 as
/// R16G16_UINT, the displacement h along the interpolated normal and that of the vertex's morph
/// target as R32G32_SFLOAT, and the sideways offset o as R32G32B32_SFLOAT, metres
/// (runtime/PatchDraw.h PatchVertexDisplacement: computed in double here, once per residency,
/// so that the shader draws the vertex at its terrain point, or morphs it towards its target).
struct PatchGpuVertex final {
  std::uint16_t b1;                   ///< formats::PatchVertex::b1
  std::uint16_t b2;                   ///< formats::PatchVertex::b2
  float heightMeters;                 ///< h, the displacement along the interpolated normal
  float targetHeightMeters;           ///< h of its morph target
  std::array<float, 3> offsetMeters;  ///< o, the sideways offset to its terrain point
};
static_assert(sizeof(PatchGpuVertex) == 24);

/// One missing patch (key.kind() Patch: `node`) or tile (Tile: `tile`) and where its decoded
/// bytes go in the output.
struct DecodeJob final {
  ResidentKey key;                ///< which patch or tile, and its kind
  runtime::NodeKey node;          ///< the patch's node (kind Patch)
  runtime::TileKey tile;          ///< the tile (kind Tile)
  std::uint64_t offset = 0;       ///< first byte in the output (layout() sets it)
  std::uint64_t bytes = 0;        ///< patches: vertices then 16-bit indices; tiles: colour
                                  ///< texels, then (at normalTileOffset()) normal-map texels
  std::uint64_t vertexBytes = 0;  ///< patches: the vertex part of `bytes`
};

/// Decodes jobs of one dataset. The DatasetView (and the bytes under it) must outlive it.
class DecodeScheduler final {
 public:
  /// Every job's offset is a multiple of this (buffer-to-image copies need 4 bytes and the
  /// 8-byte BC1 block).
  static constexpr std::uint64_t kAlignment = 16;

  /// Tiles are decoded to `tileTexels`: the dataset's own format, or RGBA8 (BC1 expanded), and
  /// their normal maps to normalTexels(tileTexels); patch vertices with their heights times
  /// `exaggeration` (runtime::PatchVertexPlacement).
  DecodeScheduler(const runtime::DatasetView& dataset, formats::TexelFormat tileTexels,
                  double exaggeration = 1.0) noexcept;

  /// The texel format the dataset's tiles are stored in (manifest.json's texture_format).
  static formats::TexelFormat datasetTexels(const runtime::DatasetView& dataset) noexcept;
  /// The normal maps' texel format that goes with colour texels `tileTexels`: BC5 beside BC1
  /// (a device that samples one samples the other), else RG8 (BC5 expanded).
  static formats::TexelFormat normalTexels(formats::TexelFormat tileTexels) noexcept {
    return tileTexels == formats::TexelFormat::Bc1 ? formats::TexelFormat::Bc5
                                                   : formats::TexelFormat::Rg8;
  }
  /// Bytes of one decoded tile: its colour texels, then its normal-map texels.
  std::uint64_t tileBytes() const noexcept { return tileBytes_; }
  /// Where a decoded tile's normal-map texels start (a multiple of kAlignment).
  std::uint64_t normalTileOffset() const noexcept { return normalOffset_; }
  /// The same for tiles of `dataset` decoded to `tileTexels`.
  static std::uint64_t normalTileOffset(const runtime::DatasetView& dataset,
                                        formats::TexelFormat tileTexels) noexcept;

  /// Sets every job's offset, bytes and vertexBytes: consecutive in job order, each offset
  /// aligned to kAlignment. Returns the bytes the output needs. Patch jobs must name drawable
  /// nodes (vertices and triangles > 0).
  std::uint64_t layout(std::span<DecodeJob> jobs) const;

  /// Decodes every job (laid out by layout()) into out.subspan(offset, bytes), in parallel.
  /// `out` must hold layout()'s bytes. Errors: CorruptData for a blob that does not decode or
  /// does not match its record or the manifest, naming the face file and the blob's offset
  /// ("FILE@OFFSET"); the first failing job in job order is reported.
  formats::Result<void> decode(std::span<const DecodeJob> jobs, std::span<std::byte> out) const;

 private:
  formats::Result<void> decodePatch(const runtime::NodeKey& key, std::span<std::byte> out) const;
  formats::Result<void> decodeTile(const runtime::TileKey& key, std::span<std::byte> out) const;

  const runtime::DatasetView* dataset_;
  formats::TexelFormat tileTexels_;
  double exaggeration_;
  std::uint64_t normalOffset_;
  std::uint64_t tileBytes_;
};

}  // namespace pbdam::streaming
