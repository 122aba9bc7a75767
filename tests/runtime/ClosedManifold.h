// Test aid: checks that a cut's triangles, at the positions the shader computes (geomorph
// included: each patch with its cut's morph weights and its vertices' morph targets), form a
// closed, consistently oriented 2-manifold (watertight, no T-junctions or cracks).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <unordered_map>
#include <vector>

#include "RuntimeTestSupport.h"
#include "pbdam/runtime/PatchDraw.h"
#include "pbdam/runtime/Refinement.h"

namespace pbdam::test {

// Welds bit-identical positions and checks that the triangles form a closed, consistently
// oriented 2-manifold. Returns the Euler characteristic (V − E + F) or reports failures.
struct MeshCheck {
  std::size_t vertices = 0, edges = 0, triangles = 0;
  std::size_t badEdges = 0, degenerate = 0;
  /// Welded vertices shared by patches of different levels, one of them morphing (its
  /// parent's weight strictly between 0 and 1, and some of its vertices moved by it): where a
  /// morphing cut could crack.
  std::size_t morphingSharedVertices = 0;
  long euler() const {
    return static_cast<long>(vertices) - static_cast<long>(edges) + static_cast<long>(triangles);
  }
};

struct PositionKey {
  std::array<std::uint32_t, 3> bits;
  bool operator==(const PositionKey&) const = default;
};
struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const noexcept {
    return (std::size_t{k.bits[0]} * 0x9E3779B97F4A7C15ull) ^
           (std::size_t{k.bits[1]} * 0xC2B2AE3D27D4EB4Full) ^ (std::size_t{k.bits[2]} << 1);
  }
};

inline MeshCheck checkClosedManifold(const runtime::DatasetView& view, const runtime::Cut& cut,
                                     const glm::dvec3& eye, PatchStore& store,
                                     double exaggeration = 1.0) {
  std::unordered_map<PositionKey, std::uint32_t, PositionKeyHash> ids;
  ids.reserve(cut.vertices);
  std::vector<std::uint64_t> directed;  // from << 32 | to
  directed.reserve(3 * cut.triangles);
  MeshCheck check;
  std::vector<std::uint32_t> local;
  using namespace formats;
  using namespace runtime;
  struct Welded {
    int minLevel = 1 << 30, maxLevel = -1;
    bool morphing = false;
  };
  std::vector<Welded> welded;
  for (const CutPatch& p : cut.patches) {
    const NodeRecord record = view.node(p.node);
    PatchDrawInput input{.node = p.node, .record = record};
    input.morph = p.morph;
    const PatchDrawRecord draw = makePatchDrawRecord(view, input, eye);
    const PatchVertexPlacement placement(view, p.node, record, exaggeration);
    const PatchMesh& mesh = store.mesh(p.node);
    const std::vector<std::int32_t>& targets = store.targets(p.node);
    bool patchMorphs = false;
    if (p.morph[0] > 0.0f && p.morph[0] < 1.0f) {
      for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
        patchMorphs = patchMorphs || targets[v] != mesh.vertices[v].heightSteps;
      }
    }
    local.resize(mesh.vertices.size());
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      const PatchVertex& pv = mesh.vertices[v];
      PatchVertexDisplacement d, t;
      EXPECT_TRUE(placement.displacement(pv, d));
      EXPECT_TRUE(placement.displacement(PatchVertex{pv.b1, pv.b2, targets[v]}, t));
      d.targetHeightMeters = t.heightMeters;
      const glm::vec3 pos = shaderVertexPosition(draw, pv.b1, pv.b2, d);
      PositionKey key{};
      std::memcpy(key.bits.data(), &pos, sizeof(key.bits));
      local[v] = ids.try_emplace(key, static_cast<std::uint32_t>(ids.size())).first->second;
      welded.resize(ids.size());
      Welded& w = welded[local[v]];
      w.minLevel = std::min(w.minLevel, p.level);
      w.maxLevel = std::max(w.maxLevel, p.level);
      w.morphing = w.morphing || patchMorphs;
    }
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      const std::array<std::uint32_t, 3> c{local[mesh.indices[t]], local[mesh.indices[t + 1]],
                                           local[mesh.indices[t + 2]]};
      ++check.triangles;
      if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) ++check.degenerate;
      for (int e = 0; e < 3; ++e) {
        const std::uint64_t from = c[static_cast<std::size_t>(e)];
        const std::uint64_t to = c[static_cast<std::size_t>((e + 1) % 3)];
        directed.push_back((from << 32) | to);
      }
    }
  }
  check.vertices = ids.size();
  for (const Welded& w : welded) {
    check.morphingSharedVertices += static_cast<std::size_t>(w.morphing && w.minLevel < w.maxLevel);
  }
  // Every directed edge once, and its reverse once: every edge is shared by exactly two
  // triangles, oriented consistently (a closed, oriented 2-manifold). The edges are grouped by
  // their first vertex (a counting sort: vertex ids are dense), so that each edge's twin and
  // reverse are looked for among a few neighbours, not by a binary search of all the edges.
  std::vector<std::size_t> first(check.vertices + 1, 0);
  for (const std::uint64_t edge : directed) ++first[(edge >> 32) + 1];
  for (std::size_t v = 0; v < check.vertices; ++v) first[v + 1] += first[v];
  std::vector<std::uint32_t> to(directed.size());
  std::vector<std::size_t> fill(first.begin(), first.end() - 1);
  for (const std::uint64_t edge : directed) {
    to[fill[edge >> 32]++] = static_cast<std::uint32_t>(edge);
  }
  const auto count = [&](std::uint32_t from, std::uint32_t target) {
    return std::count(to.begin() + static_cast<std::ptrdiff_t>(first[from]),
                      to.begin() + static_cast<std::ptrdiff_t>(first[from + 1]), target);
  };
  for (std::uint32_t from = 0; from < check.vertices; ++from) {
    for (std::size_t k = first[from]; k < first[from + 1]; ++k) {
      const bool repeated = count(from, to[k]) > 1;
      if (repeated || count(to[k], from) == 0) ++check.badEdges;
    }
  }
  check.edges = directed.size() / 2;
  return check;
}

}  // namespace pbdam::test
