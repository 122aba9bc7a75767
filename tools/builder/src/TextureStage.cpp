// The texture stage of a build (DatasetBuild.h; docs/builder.md): the DEM read again and checked
// against the one the build started with, then the shaded-relief (or imagery) tiles of the
// texture quadtree, a contiguous range of them per rank built with TBB, streamed into the
// rank's checkpoint part file and recorded by rank 0.
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "DatasetBuild.h"
#include "pbdam/builder/ResidentTrimmer.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/TextureTile.h"

using namespace pbdam::formats;

namespace pbdam::builder {

Result<void> DatasetBuild::rereadDem() {
  const auto t0 = Clock::now();
  auto dem = readDem(o_.demPath, demReadOptions(o_));
  if (!dem) return std::move(dem).error();
  const std::string crc = demCrc32(*dem);
  for (const auto& [key, value] : state_.fingerprint) {
    if (key == "dem-crc32" && value != crc) {
      return invalidArgument(o_.demPath.string()
                                 .append(": changed during the build (CRC-32 ")
                                 .append(crc)
                                 .append(", was ")
                                 .append(value)
                                 .append(" when the build started)"));
    }
  }
  {
    std::lock_guard lock(residentMutex_);  // the trimmer releases the DEM's pages too
    in_.dem = std::move(dem).value();
  }
  char line[120];
  std::snprintf(line, sizeof line, "texture: DEM read again in %.1f s",
                std::chrono::duration<double>(Clock::now() - t0).count());
  log(line);
  return {};
}

TextureSource DatasetBuild::textureSource() const {
  const SampleGrid& grid = *grid_;
  TextureSource source;
  source.planet = *in_.planet;
  if (in_.composite) {
    // Shaded relief of the composite: the insets' texels at their own density.
    const CompositeSurface* composite = &*in_.composite;
    source.heightMeters = [composite](double lat, double lon) {
      return composite->heightAt(lat, lon);
    };
  } else {
    source.heightMeters = heightFunctionFromGrid(*in_.dem, true);
  }
  source.ramp.hasOcean = grid.minHeightMeters() < 0.0f && in_.demSource.body == "earth";
  if (!source.ramp.hasOcean && in_.planet->name() == "earth") source.ramp.hasOcean = true;
  source.ramp.minMeters = static_cast<double>(grid.minHeightMeters());
  source.ramp.maxMeters =
      std::max(static_cast<double>(grid.maxHeightMeters()), source.ramp.minMeters + 1.0);
  if (in_.imagery) source.imagery = &*in_.imagery;
  // Insets with imagery draw it over what lies below, with the weight their heights blend by
  // (each spec's imagery over its own tiles of its surface).
  for (std::size_t i = 0; i < in_.insetImagery.size(); ++i) {
    if (!in_.insetImagery[i]) continue;
    const CompositeSurface* composite = &*in_.composite;
    source.layers.push_back({&*in_.insetImagery[i], [composite, i](double lat, double lon) {
                               return composite->specWeight(i, lat, lon);
                             }});
  }
  if (source.imagery != nullptr || !source.layers.empty()) source.imageryShadingStrength = 0.35;
  return source;
}

bool DatasetBuild::buildTile(const TextureSource& source, std::uint64_t key,
                             std::uint64_t tilesPerFace, std::vector<std::byte>& blob,
                             std::vector<std::byte>& normalBlob, float& errorMeters) const {
  const auto face = static_cast<int>(key / tilesPerFace);
  const std::uint64_t heap = key % tilesPerFace;
  std::uint32_t level = 0;
  while (((std::uint64_t{1} << (2 * (level + 1))) - 1) / 3 <= heap) ++level;
  const std::uint64_t within = heap - ((std::uint64_t{1} << (2 * level)) - 1) / 3;
  TextureTileRequest request;
  request.face = face;
  request.level = static_cast<int>(level);
  request.qi = static_cast<std::uint32_t>(within & ((std::uint64_t{1} << level) - 1));
  request.qj = static_cast<std::uint32_t>(within >> level);
  request.sizeTexels = o_.textureTileTexels;
  request.borderTexels = kTextureBorderTexels;
  auto tile = buildTextureTile(source, request);
  if (!tile) return false;
  TextureTileImage image = std::move(tile->image);
  if (o_.textureFormat == TexelFormat::Bc1) {
    auto bc1 = compressBc1(image, o_.bc1Quality);
    if (!bc1) return false;
    image = std::move(bc1).value();
  }
  auto encoded = encodeTextureTile(image);
  if (!encoded) return false;
  blob = std::move(encoded).value();
  // The normal map beside it: BC5 beside BC1, else two bytes a texel.
  auto normals = buildNormalTile(source, request);
  if (!normals) return false;
  TextureTileImage normalImage = std::move(normals).value();
  if (o_.textureFormat == TexelFormat::Bc1) {
    auto bc5 = compressBc5(normalImage);
    if (!bc5) return false;
    normalImage = std::move(bc5).value();
  }
  auto normalEncoded = encodeTextureTile(normalImage);
  if (!normalEncoded) return false;
  normalBlob = std::move(normalEncoded).value();
  errorMeters = roundUpToFloat(tile->textureErrorMeters);
  return true;
}

Result<void> DatasetBuild::recordTextures(const std::vector<std::vector<std::byte>>& gathered,
                                          std::uint64_t tiles) {
  report("texture", 1.0);
  const std::string writing = "writing the texture checkpoint";
  state_.textureComplete = true;
  state_.textureParts = static_cast<std::uint32_t>(comm_.size());
  if (auto w = checkpoint_.writeState(state_); !w) return fail(writing, w.error());
  textureComplete_ = true;
  std::string line = "texture: " + std::to_string(tiles) + " tiles";
  char buf[120];
  for (std::size_t r = 0; r < gathered.size(); ++r) {
    const auto footer = decodeTexturePartFooter(gathered[r], "rank " + std::to_string(r));
    const std::uint64_t count = footer ? footer->tiles : 0;
    const double s = footer ? footer->seconds : 0.0;
    std::snprintf(buf, sizeof buf, "%s rank %zu %llu in %.1f s (%.1f/s)", r == 0 ? ";" : ",", r,
                  static_cast<unsigned long long>(count), s,
                  s > 0.0 ? static_cast<double>(count) / s : 0.0);
    line += buf;
  }
  log(line);
  return {};
}

Result<void> DatasetBuild::buildTextures() {
  const std::uint32_t textureLevels =
      textureLevelCount(in_.n, o_.textureTileTexels, kTextureBorderTexels);
  const std::uint64_t tilesPerFace = ((std::uint64_t{1} << (2 * textureLevels)) - 1) / 3;
  // The tiles that exist (face · tilesPerFace + heap index); all of them for a complete forest.
  const std::vector<std::uint64_t> keys = plan_.tiles(textureLevels);
  const std::uint64_t tiles = keys.empty() ? 6 * tilesPerFace : keys.size();
  // Named copies, not a structured binding: the tile lambda below captures `begin`.
  const auto share = shareOf(tiles, comm_.rank(), comm_.size());
  const std::uint64_t begin = share.first;
  const std::uint64_t end = share.second;
  const std::string item =
      "building texture tiles " + rangeText(begin, end) + " of " + std::to_string(tiles);
  announce("texture", "tiles", tiles);
  if (!in_.dem) {
    if (auto r = rereadDem(); !r) return fail(item, r.error());
  }
  const TextureSource source = textureSource();
  const auto t0 = Clock::now();
  const std::uint64_t mine = end - begin;
  const auto ranks = static_cast<std::uint32_t>(comm_.size());
  auto file = checkpoint_.startFile(Checkpoint::Kind::Texture, 0,
                                    static_cast<std::uint32_t>(comm_.rank()), ranks);
  if (!file) return fail(item, file.error());
  const auto threads =
      static_cast<std::uint64_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
  const std::uint64_t batch = 16 * threads;  // tiles in memory at once
  std::vector<std::vector<std::byte>> blobs;
  std::vector<std::vector<std::byte>> normalBlobs;
  std::vector<float> errors;
  std::atomic<std::uint64_t> done{0};
  std::atomic<std::int64_t> failedTile{-1};
  const auto caller = std::this_thread::get_id();
  auto lastReport = Clock::now();
  for (std::uint64_t first = 0; first < mine && failedTile < 0; first += batch) {
    const std::uint64_t count = std::min(batch, mine - first);
    blobs.assign(count, {});
    normalBlobs.assign(count, {});
    errors.assign(count, 0.0f);
    tbb::parallel_for(std::uint64_t{0}, count, [&](std::uint64_t j) {
      const std::uint64_t k = begin + first + j;
      if (!buildTile(source, keys.empty() ? k : keys[k], tilesPerFace, blobs[j], normalBlobs[j],
                     errors[j])) {
        failedTile = static_cast<std::int64_t>(k);
        return;
      }
      // Over the resident budget, a coarse tile's DEM pages go with it, not at the trimmer's
      // tick (a coarse tile samples the DEM across its whole area).
      if (overResidentBudget(o_.residentBudgetBytes)) releaseResident();
      ++done;
      if (std::this_thread::get_id() == caller && root() &&
          Clock::now() - lastReport > std::chrono::milliseconds(100)) {
        lastReport = Clock::now();
        report("texture", static_cast<double>(done.load()) /
                              static_cast<double>(std::max<std::uint64_t>(mine, 1)));
      }
    });
    if (failedTile >= 0) break;
    ByteWriter w;
    for (std::uint64_t j = 0; j < count; ++j) putTileEntry(w, errors[j], blobs[j], normalBlobs[j]);
    if (auto r = file->append(w.bytes()); !r) return fail(item, r.error());
  }
  blobs.clear();
  normalBlobs.clear();
  if (failedTile >= 0) {
    return fail(item,
                makeError(ErrorCode::Internal, "texture tile " + std::to_string(failedTile.load()) +
                                                   " could not be built"));
  }
  const TexturePartFooter footer{begin, mine,
                                 std::chrono::duration<double>(Clock::now() - t0).count()};
  const std::vector<std::byte> summary = encodeTexturePartFooter(footer);
  if (auto r = file->append(summary); !r) return fail(item, r.error());
  if (auto r = file->finish(); !r) return fail(item, r.error());
  auto gathered = comm_.allGather(summary);
  if (!root()) {
    textureComplete_ = true;
    return {};
  }
  return recordTextures(gathered, tiles);
}

}  // namespace pbdam::builder
