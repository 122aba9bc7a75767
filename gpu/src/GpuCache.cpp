// GpuCache: pools, LRU and pipeline shared by the renderers of one dataset (GpuCache.h;
// docs/architecture.md "Streaming", [P-BDAM 2003] §4.4). The per-pass protocol lives in
// TerrainRenderer.cpp.
#include "pbdam/gpu/GpuCache.h"

#include <algorithm>
#include <cstdio>
#include <string>
#include <unordered_set>

#include "GpuCacheState.h"
#include "pbdam/gpu/OffscreenTarget.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"
#include "pbdam/runtime/Selection.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

using namespace pbdam::streaming;

namespace pbdam::gpu {
namespace {

std::string mebibytes(std::uint64_t bytes) {
  char text[64];
  std::snprintf(text, sizeof text, "%.2f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  return text;
}

bool deviceSamples(const VulkanContext& context, VkFormat format) {
  if (!context.caps().textureCompressionBC) return false;
  VkFormatProperties properties{};
  vkGetPhysicalDeviceFormatProperties(context.physicalDevice(), format, &properties);
  const VkFormatFeatureFlags needed = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT |
                                      VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                      VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
  return (properties.optimalTilingFeatures & needed) == needed;
}

}  // namespace

TextureChoice chooseTexture(const VulkanContext& context, const DatasetView& dataset,
                            bool forceRgba8) {
  const std::uint32_t size = dataset.manifest().textureTileTexels;
  TextureChoice choice;
  if (DecodeScheduler::datasetTexels(dataset) == TexelFormat::Bc1 && !forceRgba8 &&
      deviceSamples(context, VK_FORMAT_BC1_RGB_UNORM_BLOCK) &&
      deviceSamples(context, VK_FORMAT_BC5_UNORM_BLOCK)) {
    choice.format = VK_FORMAT_BC1_RGB_UNORM_BLOCK;
    choice.texels = TexelFormat::Bc1;
    choice.normalFormat = VK_FORMAT_BC5_UNORM_BLOCK;
  }
  const std::uint64_t colour = textureTileDataBytes(size, choice.texels);
  const std::uint64_t normal = textureTileDataBytes(dataset.manifest().normalTileTexels(),
                                                    DecodeScheduler::normalTexels(choice.texels));
  choice.slotBytes = colour == 0 || normal == 0 ? 0 : colour + normal;
  return choice;
}

/// The smallest budget that draws any patch: one patch slot and two tile slots, its own tile and
/// the coarser one it may blend in (texture morph).
std::uint64_t minimumOf(std::uint64_t patchSlot, std::uint64_t tileSlot) {
  return patchSlot + 2 * tileSlot;
}

std::uint64_t patchSlotBytes(const DatasetView& dataset) {
  return std::uint64_t{sizeof(PatchGpuVertex)} * dataset.maxPatchVertices() +
         std::uint64_t{6} * dataset.maxPatchTriangles();
}

Result<std::shared_ptr<GpuCache>> GpuCache::create(VulkanContext& context,
                                                   const DatasetView& dataset,
                                                   const GpuCacheOptions& options) {
  auto state = std::make_unique<State>();
  state->context = &context;
  state->dataset = &dataset;
  state->texture = chooseTexture(context, dataset, options.forceRgba8Textures);
  state->exaggeration = options.exaggeration;
  state->patchSlot = patchSlotBytes(dataset);
  state->maxIndices = 3 * dataset.maxPatchTriangles();
  if (state->texture.slotBytes == 0 || dataset.maxPatchVertices() == 0) {
    return makeError(ErrorCode::CorruptData,
                     "dataset has no drawable patches or an invalid texture tile size");
  }
  const std::uint64_t minimum = minimumOf(state->patchSlot, state->texture.slotBytes);
  if (options.budgetBytes < minimum) {
    return makeError(ErrorCode::InvalidArgument,
                     "GPU cache budget of " + std::to_string(options.budgetBytes) + " bytes (" +
                         mebibytes(options.budgetBytes) + ") is below the minimum of " +
                         std::to_string(minimum) + " bytes (" + mebibytes(minimum) +
                         ") that one patch slot (" + std::to_string(dataset.maxPatchVertices()) +
                         " vertices, " + std::to_string(dataset.maxPatchTriangles()) +
                         " triangles: " + std::to_string(state->patchSlot) +
                         " bytes) and two texture tiles (a patch's own and its parent's, " +
                         std::to_string(state->texture.slotBytes) + " bytes each) need");
  }

  auto pipeline =
      PatchPipeline::create(context, OffscreenTarget::kColorFormat, OffscreenTarget::kDepthFormat);
  if (!pipeline) return std::move(pipeline).error();
  state->pipeline = std::move(*pipeline);

  state->lru.emplace(options.budgetBytes,
                     std::array<std::uint64_t, 2>{state->patchSlot, state->texture.slotBytes});
  const std::uint32_t patchCapacity = state->lru->capacity(ResidentKind::Patch);
  const std::uint32_t tileCapacity = state->lru->capacity(ResidentKind::Tile);
  state->patches = PatchPool(dataset.maxPatchVertices(), state->maxIndices, patchCapacity,
                             static_cast<std::uint32_t>(std::clamp<std::uint64_t>(
                                 options.chunkBytes / state->patchSlot, 1, patchCapacity)));

  const std::uint32_t tileTexels = dataset.manifest().textureTileTexels;
  VkImageFormatProperties formatProperties{};
  if (VkResult r = vkGetPhysicalDeviceImageFormatProperties(
          context.physicalDevice(), state->texture.format, VK_IMAGE_TYPE_2D,
          VK_IMAGE_TILING_OPTIMAL, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, 0,
          &formatProperties);
      r != VK_SUCCESS) {
    return vulkanError(r, "texture tiles of " + std::to_string(tileTexels) + " texels");
  }
  const auto layersPerPage = static_cast<std::uint32_t>(std::clamp<std::uint64_t>(
      std::min<std::uint64_t>(options.chunkBytes / state->texture.slotBytes,
                              formatProperties.maxArrayLayers),
      1, tileCapacity));
  TileFormats formats;
  formats.colour = state->texture.format;
  formats.colourTexels = tileTexels;
  formats.normal = state->texture.normalFormat;
  formats.normalTexels = dataset.manifest().normalTileTexels();
  formats.normalOffset = DecodeScheduler::normalTileOffset(dataset, state->texture.texels);
  auto tiles =
      TilePool::create(context, formats, state->texture.slotBytes, tileCapacity, layersPerPage,
                       state->pipeline.tilesSetLayout(), state->pipeline.sampler());
  if (!tiles) return std::move(tiles).error();
  state->tiles = std::move(*tiles);
  return std::shared_ptr<GpuCache>(new GpuCache(std::move(state)));
}

std::uint64_t GpuCache::minimumBytes(const VulkanContext& context, const DatasetView& dataset,
                                     bool forceRgba8Textures) {
  return minimumOf(patchSlotBytes(dataset),
                   chooseTexture(context, dataset, forceRgba8Textures).slotBytes);
}

std::uint64_t GpuCache::bytesForEverything(const VulkanContext& context, const DatasetView& dataset,
                                           bool forceRgba8Textures) {
  std::uint64_t patches = 0;
  std::unordered_set<std::uint64_t> tiles;
  for (const DiamondIndex::Node& place : DiamondIndex(dataset).nodes) {
    if (!drawable(dataset.node(place.key))) continue;
    ++patches;
    tiles.insert(packKey(dataset.tileOf(place.key)));
  }
  return patches * patchSlotBytes(dataset) +
         tiles.size() * chooseTexture(context, dataset, forceRgba8Textures).slotBytes;
}

GpuCache::GpuCache(std::unique_ptr<State> state) noexcept : state_(std::move(state)) {}
GpuCache::~GpuCache() = default;

std::uint64_t GpuCache::budgetBytes() const noexcept { return state_->lru->budgetBytes(); }

bool GpuCache::usesBc1Textures() const noexcept {
  return state_->texture.texels == TexelFormat::Bc1;
}

GpuCacheStats GpuCache::stats() const {
  const std::lock_guard<std::mutex> lock(state_->mutex);
  GpuCacheStats s;
  s.budgetBytes = state_->lru->budgetBytes();
  s.residentBytes = state_->lru->residentBytes();
  s.pinnedBytes = state_->lru->pinnedBytes();
  s.poolBytes = state_->patches.allocatedBytes() + state_->tiles.allocatedBytes();
  s.residentPatches = state_->lru->count(ResidentKind::Patch);
  s.residentTiles = state_->lru->count(ResidentKind::Tile);
  s.waits = state_->waits;
  s.leases = state_->leases;
  s.lockWaitMs = state_->lockWaitMs;
  s.lockHeldMs = state_->lockHeldMs;
  return s;
}

bool GpuCache::holds(const runtime::NodeKey& patch) const {
  const std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->lru->find(ResidentKey::patch(patch)).has_value();
}

bool GpuCache::holds(const runtime::TileKey& tile) const {
  const std::lock_guard<std::mutex> lock(state_->mutex);
  return state_->lru->find(ResidentKey::tile(tile)).has_value();
}

}  // namespace pbdam::gpu
