// Decoding a pass's misses into caller-provided host memory without Vulkan (DecodeScheduler), on
// the real MOLA test dataset: the layout, the decoded bytes against the codecs' own output, and
// a corrupt blob reported with its file and offset.
#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "PrivateCopy.h"
#include "TestData.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/streaming/DecodeScheduler.h"
#include "pbdam/streaming/MappedDataset.h"

#if defined(__SANITIZE_THREAD__)
#include <tbb/global_control.h>
#endif

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::streaming {
namespace {

#if defined(__SANITIZE_THREAD__)
// As gpu/src/SanitizerSupport.cpp does for the renderer: Debian's libtbb is not instrumented, so
// TSan reports TBB's own task handoffs as races; under TSan the decoding runs on the calling
// thread. The parallel path is checked by the release and ASan runs.
const tbb::global_control serialTbbUnderTsan(tbb::global_control::max_allowed_parallelism, 1);
#endif

/// Patches and tiles of one face's top levels that have data.
std::vector<DecodeJob> someJobs(const DatasetView& view) {
  std::vector<DecodeJob> jobs;
  for (std::uint64_t heap = 0; heap < 15; ++heap) {
    const NodeKey node{2, 0, heap};
    const NodeRecord n = view.node(node);
    if (n.vertexCount == 0 || n.triangleCount == 0 || n.blobBytes == 0) continue;
    DecodeJob job;
    job.key = ResidentKey::patch(node);
    job.node = node;
    jobs.push_back(job);
  }
  for (std::uint64_t heap = 0; heap < 5; ++heap) {
    DecodeJob job;
    job.tile = TileKey{2, heap};
    job.key = ResidentKey::tile(job.tile);
    jobs.push_back(job);
  }
  return jobs;
}

TEST(DecodeScheduler, DecodesPatchesAndTilesIntoTheCallersMemory) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  const DecodeScheduler decoder(view, TexelFormat::Rgba8);
  std::vector<DecodeJob> jobs = someJobs(view);
  ASSERT_GT(jobs.size(), 5u);
  const std::uint64_t total = decoder.layout(jobs);
  std::uint64_t end = 0;
  for (const DecodeJob& job : jobs) {
    EXPECT_EQ(job.offset % DecodeScheduler::kAlignment, 0u);
    EXPECT_GE(job.offset, end);  // consecutive, never overlapping
    end = job.offset + job.bytes;
  }
  EXPECT_EQ(total, end);
  std::vector<std::byte> out(total, std::byte{0xee});
  const Result<void> decoded = decoder.decode(jobs, out);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;

  for (const DecodeJob& job : jobs) {
    if (job.key.kind() == ResidentKind::Patch) {
      // Vertices as the pools hold them, then the codec's indices.
      const NodeRecord n = view.node(job.node);
      PatchMesh mesh;
      std::vector<std::byte> blob;
      const auto bytes = view.face(job.node.face).readPatchBlobs(n, blob);
      ASSERT_TRUE(bytes.ok());
      ASSERT_TRUE(decodePatch(bytes->patch, mesh, "test").ok());
      std::vector<std::int32_t> targets;
      ASSERT_TRUE(decodeMorphTargets(bytes->morph, mesh, targets, "test").ok());
      ASSERT_EQ(job.vertexBytes, sizeof(PatchGpuVertex) * mesh.vertices.size());
      ASSERT_EQ(job.bytes - job.vertexBytes, 2u * mesh.indices.size());
      const PatchVertexPlacement placement(view, job.node, n);
      const double step = view.manifest().heightStepMeters;
      for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
        const PatchVertex& pv = mesh.vertices[v];
        PatchGpuVertex gpu{};
        std::memcpy(&gpu, out.data() + job.offset + sizeof gpu * v, sizeof gpu);
        EXPECT_EQ(gpu.b1, pv.b1);
        EXPECT_EQ(gpu.b2, pv.b2);
        // Displacement and offset take the flat point to the vertex's terrain point: its lattice
        // point's direction at its stored height (to the offset's float rounding).
        LatticeXY q{0};
        ASSERT_TRUE(placement.latticePoint(pv.b1, pv.b2, q));
        const glm::dvec3 terrain = latticeTerrainPoint(view.planet(), view.latticeCells(),
                                                       job.node.face, q, pv.heightSteps * step);
        // The placement's cached tangents give the very bits of the shared function.
        EXPECT_TRUE(placement.terrainPoint(q, pv.heightSteps) == terrain);
        const glm::dvec3 offset(gpu.offsetMeters[0], gpu.offsetMeters[1], gpu.offsetMeters[2]);
        const PatchVertexBase base = placement.base(pv.b1, pv.b2);
        EXPECT_EQ(std::fmod(static_cast<double>(gpu.heightMeters), step), 0.0);
        const glm::dvec3 drawn =
            base.flat + static_cast<double>(gpu.heightMeters) * base.normal + offset;
        EXPECT_LE(glm::length(drawn - terrain), 1e-6 * glm::length(offset) + 1e-9);
        EXPECT_NEAR(glm::length(terrain) - view.planet().equatorialRadiusMeters(),
                    pv.heightSteps * step, 1e-6);  // MOLA: a sphere
        // The morph target's displacement over the same base: on the height grid too, on the
        // same side of the vertex's own as the target's height, the same where they agree.
        EXPECT_EQ(std::fmod(static_cast<double>(gpu.targetHeightMeters), step), 0.0);
        const double moved =
            static_cast<double>(gpu.targetHeightMeters) - static_cast<double>(gpu.heightMeters);
        EXPECT_GE(moved * static_cast<double>(targets[v] - pv.heightSteps), 0.0);
        if (targets[v] == pv.heightSteps) {
          EXPECT_EQ(gpu.targetHeightMeters, gpu.heightMeters);
        }
      }
      EXPECT_EQ(std::memcmp(out.data() + job.offset + job.vertexBytes, mesh.indices.data(),
                            job.bytes - job.vertexBytes),
                0);
    } else {
      // RGBA8 texels of the tile (BC1 tiles expanded), then RG8 texels of its normal map (BC5
      // expanded) at the normal map's offset.
      const TextureRecord r = view.textureNode(job.tile);
      std::vector<std::byte> blob;
      const auto bytes = view.face(job.tile.face).readTextureBlobs(r, blob);
      ASSERT_TRUE(bytes.ok());
      auto tile = decodeTextureTile(bytes->colour, "test");
      ASSERT_TRUE(tile.ok());
      if (tile->format != TexelFormat::Rgba8) tile = expandToRgba8(*tile);
      ASSERT_TRUE(tile.ok());
      auto normals = decodeTextureTile(bytes->normal, "test");
      ASSERT_TRUE(normals.ok());
      if (normals->format != TexelFormat::Rg8) normals = expandToRg8(*normals);
      ASSERT_TRUE(normals.ok());
      ASSERT_EQ(job.bytes, decoder.tileBytes());
      ASSERT_LE(tile->data.size(), decoder.normalTileOffset());
      ASSERT_EQ(decoder.normalTileOffset() + normals->data.size(), job.bytes);
      EXPECT_EQ(std::memcmp(out.data() + job.offset, tile->data.data(), tile->data.size()), 0);
      EXPECT_EQ(std::memcmp(out.data() + job.offset + decoder.normalTileOffset(),
                            normals->data.data(), normals->data.size()),
                0);
    }
  }
}

TEST(DecodeScheduler, NamesTheFileAndOffsetOfACorruptBlob) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = test::privateCopy(shared, temp);
  NodeKey victim{2, 0, 3};
  std::uint64_t offset = 0;
  std::string file;
  {
    auto dataset = MappedDataset::open(dir);
    ASSERT_TRUE(dataset.ok()) << dataset.error().message;
    const NodeRecord n = (*dataset)->view().node(victim);
    ASSERT_GT(n.blobBytes, 16u);
    offset = n.blobOffset;
    file = (*dataset)->view().manifest().faces[victim.face].file;
  }
  {
    std::fstream f(dir / file, std::ios::in | std::ios::out | std::ios::binary);
    ASSERT_TRUE(f.good());
    f.seekp(static_cast<std::streamoff>(offset));
    const std::vector<char> garbage(16, '\x5a');
    f.write(garbage.data(), static_cast<std::streamsize>(garbage.size()));
  }
  auto dataset = MappedDataset::open(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.error().message;
  const DatasetView& view = (*dataset)->view();
  const DecodeScheduler decoder(view, DecodeScheduler::datasetTexels(view));
  std::vector<DecodeJob> jobs = someJobs(view);
  std::vector<std::byte> out(decoder.layout(jobs));
  const Result<void> decoded = decoder.decode(jobs, out);
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.error().code, ErrorCode::CorruptData);
  EXPECT_NE(decoded.error().message.find(file), std::string::npos) << decoded.error().message;
  std::string at = "@";
  at += std::to_string(offset);
  EXPECT_NE(decoded.error().message.find(at), std::string::npos) << decoded.error().message;
}

}  // namespace
}  // namespace pbdam::streaming
