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
  const formats::PatchMesh& mesh(const runtime::NodeKey& key) {
    auto [it, inserted] = meshes_.try_emplace(runtime::packKey(key));
    if (inserted) {
      const formats::NodeRecord record = view_.node(key);
      std::vector<std::byte> blob;
      const auto bytes = view_.face(key.face).readPatchBlob(record, blob);
      EXPECT_TRUE(bytes.ok()) << (bytes.ok() ? "" : bytes.error().message);
      if (!bytes.ok()) return it->second;
      const auto decoded = formats::decodePatch(*bytes, it->second, "test");
      EXPECT_TRUE(decoded.ok()) << (decoded.ok() ? "" : decoded.error().message);
    }
    return it->second;
  }

 private:
  const runtime::DatasetView& view_;
  std::map<std::uint64_t, formats::PatchMesh> meshes_;
};

}  // namespace pbdam::test
