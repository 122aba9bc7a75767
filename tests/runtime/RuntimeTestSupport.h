// Shared by the runtime tests that read real datasets: decoded patches cached per node, and the
// camera-relative vertex positions a cut's patches get, computed exactly as the vertex shader
// computes them (runtime/PatchDraw.h).
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <random>

#include "TestData.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::test {

/// Decodes patches on first use and keeps them.
class PatchStore final {
 public:
  explicit PatchStore(const runtime::DatasetView& view) : view_(view) {}
  const formats::PatchMesh& mesh(const runtime::NodeKey& key) { return entry(key).mesh; }
  /// The patch's morph targets (dataset format 4), one per vertex of mesh().
  const std::vector<std::int32_t>& targets(const runtime::NodeKey& key) {
    return entry(key).targets;
  }

 private:
  struct Entry {
    formats::PatchMesh mesh;
    std::vector<std::int32_t> targets;
  };
  Entry& entry(const runtime::NodeKey& key) {
    auto [it, inserted] = meshes_.try_emplace(runtime::packKey(key));
    if (inserted) {
      const formats::NodeRecord record = view_.node(key);
      std::vector<std::byte> blob;
      const auto bytes = view_.face(key.face).readPatchBlobs(record, blob);
      EXPECT_TRUE(bytes.ok()) << (bytes.ok() ? "" : bytes.error().message);
      if (!bytes.ok()) return it->second;
      const auto decoded = formats::decodePatch(bytes->patch, it->second.mesh, "test");
      EXPECT_TRUE(decoded.ok()) << (decoded.ok() ? "" : decoded.error().message);
      const auto targets =
          formats::decodeMorphTargets(bytes->morph, it->second.mesh, it->second.targets, "test");
      EXPECT_TRUE(targets.ok()) << (targets.ok() ? "" : targets.error().message);
    }
    return it->second;
  }

  const runtime::DatasetView& view_;
  std::map<std::uint64_t, Entry> meshes_;
};

}  // namespace pbdam::test
