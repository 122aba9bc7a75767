// Mesh efficiency (issue: P-BDAM vs a right-triangulated irregular network, [P-BDAM 2003] §2):
// triangles of uniform-error cuts of a built dataset next to those of an RTIN — longest-edge
// bisection of the same cube-map lattice samples down to single cells — at the same maximum
// errors. Both use the exact vertical error against every lattice sample a triangle covers,
// saturated over the diamond DAG; the P-BDAM column with its stored errors (which add the
// representation term (quantisation and offset rounding), the chord term and the source-DEM
// deviation) is shown too.
// Prints a table and a JSON line.
//   pbdam_mesh_efficiency DATASET DEM [ERROR_M ...]      (defaults 50 200 1000)
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <string>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"
#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/streaming/MappedFile.h"

using namespace pbdam;
using namespace pbdam::builder;

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace {

/// Saturates per-node errors (dataset node ids of `lattice` at `depth`) over the diamond DAG:
/// partners share the max, parents bound their four child diamonds.
void saturate(const Lattice& lattice, int depth, std::vector<float>& error) {
  std::vector<std::pair<EdgeKey, float>> below;
  for (int level = depth; level >= 0; --level) {
    std::vector<std::pair<EdgeKey, float>> here;
    for (const Diamond& d : diamondsOfLevel(lattice, depth, level)) {
      float e = std::max(error[d[0]], error[d[1]]);
      const BinTriangle a = triangleOfNode(lattice, d[0], depth);
      const BinTriangle b = triangleOfNode(lattice, d[1], depth);
      if (level < depth) {
        for (const EdgeKey& leg :
             {lattice.edgeKey(a.face, a.apex, a.left), lattice.edgeKey(a.face, a.apex, a.right),
              lattice.edgeKey(b.face, b.apex, b.left), lattice.edgeKey(b.face, b.apex, b.right)}) {
          const auto it =
              std::lower_bound(below.begin(), below.end(), std::pair<EdgeKey, float>{leg, -1.0f});
          if (it != below.end() && it->first == leg) e = std::max(e, it->second);
        }
      }
      error[d[0]] = error[d[1]] = e;
      here.emplace_back(lattice.edgeKey(a.face, a.left, a.right), e);
    }
    std::sort(here.begin(), here.end());
    below = std::move(here);
  }
}

/// Triangles of the cut refining every node whose (saturated) error exceeds e; `perLevel`, when
/// given, receives the triangles the cut takes from each level.
std::uint64_t cutTriangles(const Lattice& lattice, int depth, const std::vector<float>& error,
                           const std::vector<std::uint32_t>& triangles, double e,
                           std::vector<std::uint64_t>* perLevel = nullptr) {
  std::uint64_t count = 0;
  if (perLevel) perLevel->assign(static_cast<std::size_t>(depth) + 1, 0);
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  for (std::uint64_t g = 0; g < 12; ++g) {
    std::function<void(std::uint64_t, int)> visit = [&](std::uint64_t index, int level) {
      const std::uint64_t id = g * perTree + index;
      if (static_cast<double>(error[id]) <= e || level == depth) {
        const std::uint64_t n = triangles.empty() ? 1 : triangles[id];
        count += n;
        if (perLevel) (*perLevel)[static_cast<std::size_t>(level)] += n;
        return;
      }
      visit(2 * index + 1, level + 1);
      visit(2 * index + 2, level + 1);
    };
    visit(0, 0);
  }
  (void)lattice;
  return count;
}

/// A lower bound on any stored-error cut at e for these leaves: a node's stored error is at
/// least (1 + r)^(depth − level) times the largest leaf error under it (the margin rule, before
/// saturation adds its neighbours'), and a patch above the leaves has at least `minTriangles`.
std::uint64_t storedCutLowerBound(int depth, const std::vector<float>& stored,
                                  const std::vector<std::uint32_t>& triangles, double margin,
                                  std::uint32_t minTriangles, double e) {
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  std::uint64_t count = 0;
  for (std::uint64_t g = 0; g < 12; ++g) {
    // The largest leaf error under every node, bottom-up in heap order.
    std::vector<double> worstLeaf(perTree, 0.0);
    for (std::uint64_t i = perTree; i-- > 0;) {
      worstLeaf[i] = 2 * i + 1 < perTree ? std::max(worstLeaf[2 * i + 1], worstLeaf[2 * i + 2])
                                         : static_cast<double>(stored[g * perTree + i]);
    }
    std::function<void(std::uint64_t, int)> visit = [&](std::uint64_t index, int level) {
      if (level == depth) {
        count += triangles[g * perTree + index];
        return;
      }
      if (std::pow(1.0 + margin, depth - level) * worstLeaf[index] <= e) {
        count += minTriangles;
        return;
      }
      visit(2 * index + 1, level + 1);
      visit(2 * index + 2, level + 1);
    };
    visit(0, 0);
  }
  return count;
}

/// Exact vertical error of every RTIN triangle down to single lattice cells: the largest
/// deviation of any lattice sample it covers from the plane of its three corners' heights.
std::vector<float> rtinErrors(const SampleGrid& grid, int depth) {
  const Lattice& lattice = grid.lattice();
  std::vector<float> error(12 * Lattice::nodesPerTree(depth), 0.0f);
  for (std::uint64_t id = 0; id < error.size(); ++id) {
    const BinTriangle t = triangleOfNode(lattice, id, depth);
    WorkPatch tri;
    tri.points = {t.apex, t.left, t.right};
    tri.indices = doubleArea(t.apex, t.left, t.right) > 0 ? std::vector<std::uint32_t>{0, 1, 2}
                                                          : std::vector<std::uint32_t>{0, 2, 1};
    error[id] = static_cast<float>(maxLatticeDeviation(grid, t.face, tri));
  }
  return error;
}

/// Where the P-BDAM vertical cuts' triangles come from, and what each level holds.
void printPerLevel(const Lattice& lattice, int depth, const std::vector<float>& stored,
                   const std::vector<float>& vertical, const std::vector<std::uint32_t>& triangles,
                   const std::vector<double>& errors) {
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  std::printf(
      "\nper level: patches, mean triangles, mean/max vertical error, mean stored error, "
      "then the vertical cuts' triangles from that level\n");
  std::vector<std::vector<std::uint64_t>> fromLevel(errors.size());
  for (std::size_t k = 0; k < errors.size(); ++k)
    cutTriangles(lattice, depth, vertical, triangles, errors[k], &fromLevel[k]);
  for (int level = 0; level <= depth; ++level) {
    const std::uint64_t first = (std::uint64_t{1} << level) - 1;
    const std::uint64_t count = std::uint64_t{1} << level;
    double tris = 0.0;
    double v = 0.0;
    double vMax = 0.0;
    double s = 0.0;
    for (std::uint64_t g = 0; g < 12; ++g) {
      for (std::uint64_t i = first; i < first + count; ++i) {
        const std::uint64_t id = g * perTree + i;
        tris += static_cast<double>(triangles[id]);
        v += static_cast<double>(vertical[id]);
        vMax = std::max(vMax, static_cast<double>(vertical[id]));
        s += static_cast<double>(stored[id]);
      }
    }
    const double n = 12.0 * static_cast<double>(count);
    std::printf("L%-2d %7.0f %8.0f %9.1f %9.1f %9.1f", level, n, tris / n, v / n, vMax, s / n);
    for (const auto& from : fromLevel)
      std::printf(" %9llu", static_cast<unsigned long long>(from[static_cast<std::size_t>(level)]));
    std::printf("\n");
  }
}

/// What the leaves alone allow: the stored errors' floor compounded by the margin.
template <class RtinCut>
void printLowerBounds(const Manifest& manifest, int depth, const std::vector<float>& stored,
                      const std::vector<std::uint32_t>& triangles,
                      const std::vector<double>& errors, RtinCut rtinCut) {
  std::printf(
      "\nlower bound on any stored cut for these leaves (margin %.2f, %u triangles a "
      "patch):",
      manifest.errorMargin, manifest.minPatchTriangles);
  for (double e : errors) {
    const std::uint64_t bound = storedCutLowerBound(depth, stored, triangles, manifest.errorMargin,
                                                    manifest.minPatchTriangles, e);
    std::printf(" %.0f m: %llu (%.2fx the RTIN)", e, static_cast<unsigned long long>(bound),
                static_cast<double>(bound) / static_cast<double>(rtinCut(e)));
  }
  std::printf("\n");
}

int run(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s DATASET DEM [ERROR_M ...]\n", argv[0]);
    return 2;
  }
  const std::filesystem::path dir = argv[1];
  std::vector<double> errors;
  for (int k = 3; k < argc; ++k) errors.push_back(std::atof(argv[k]));
  if (errors.empty()) errors = {50.0, 200.0, 1000.0};
  auto manifest = readManifest(dir);
  if (!manifest) {
    std::fprintf(stderr, "%s\n", manifest.error().message.c_str());
    return 2;
  }
  auto planet = Planet::fromSpec(manifest->planetSpec);
  auto dem = readDem(argv[2]);
  if (!planet || !dem) {
    std::fprintf(stderr, "cannot read the planet or the DEM\n");
    return 2;
  }
  const Lattice lattice(manifest->latticeCells);
  const SampleGrid grid = SampleGrid::build(*dem, *planet, lattice, lattice.sideCells());
  const auto depth = static_cast<int>(manifest->depth);
  const int rtinDepth = 2 * std::countr_zero(lattice.sideCells());
  std::vector<float> rtin = rtinErrors(grid, rtinDepth);
  saturate(lattice, rtinDepth, rtin);

  // P-BDAM: stored errors, and the same vertical lattice-sample error as the RTIN, measured on
  // the decoded patches and saturated the same way.
  const std::uint64_t perTree = Lattice::nodesPerTree(depth);
  std::vector<float> stored(12 * perTree);
  std::vector<float> vertical(12 * perTree);
  std::vector<std::uint32_t> triangles(12 * perTree);
  PatchMesh mesh;
  std::vector<std::byte> blobBuffer;
  for (std::size_t f = 0; f < 6; ++f) {
    auto file = MappedFile::open(dir / manifest->faces[f].file);
    if (!file) return 2;
    auto view = FaceView::open(file->bytes(), manifest->faces[f].file);
    if (!view) return 2;
    if (!view->completeForest()) {
      std::fprintf(stderr, "%s: adaptive depth (the RTIN comparison needs complete trees)\n",
                   manifest->faces[f].file.c_str());
      return 2;
    }
    for (std::uint64_t k = 0; k < view->header().nodeCount; ++k) {
      const std::uint64_t id = f * 2 * perTree + k;
      const NodeRecord n = view->nodeAt(k);
      stored[id] = n.errorMeters;
      triangles[id] = n.triangleCount;
      const auto blob = view->readPatchBlob(n, blobBuffer);
      if (!blob || !decodePatch(*blob, mesh, "patch")) return 2;
      const BinTriangle t = triangleOfNode(lattice, id, depth);
      WorkPatch patch;
      const LatticeXY e1 = t.left - t.apex;
      const LatticeXY e2 = t.right - t.apex;
      for (const PatchVertex& v : mesh.vertices) {
        patch.points.push_back(
            t.apex +
            LatticeXY{static_cast<std::int32_t>(
                          (v.b1 * std::int64_t{e1.x} + v.b2 * std::int64_t{e2.x}) / 32768),
                      static_cast<std::int32_t>(
                          (v.b1 * std::int64_t{e1.y} + v.b2 * std::int64_t{e2.y}) / 32768)});
      }
      patch.indices.assign(mesh.indices.begin(), mesh.indices.end());
      vertical[id] = static_cast<float>(maxLatticeDeviation(grid, t.face, patch));
    }
  }
  saturate(lattice, depth, vertical);

  std::printf("dataset %s: lattice %u cells per face side, P-BDAM depth %d, RTIN depth %d\n",
              dir.c_str(), manifest->latticeCells, depth, rtinDepth);
  std::printf("%9s %14s %14s %14s %9s %9s\n", "error_m", "rtin_tris", "pbdam_vertical",
              "pbdam_stored", "ratio_v", "ratio_s");
  std::string json = "{\"dataset\":\"" + dir.string() + "\",\"rows\":[";
  for (double e : errors) {
    const std::uint64_t r = cutTriangles(lattice, rtinDepth, rtin, {}, e);
    const std::uint64_t pv = cutTriangles(lattice, depth, vertical, triangles, e);
    const std::uint64_t ps = cutTriangles(lattice, depth, stored, triangles, e);
    const double rv = static_cast<double>(pv) / static_cast<double>(r);
    const double rs = static_cast<double>(ps) / static_cast<double>(r);
    std::printf("%9.0f %14llu %14llu %14llu %9.2f %9.2f\n", e, static_cast<unsigned long long>(r),
                static_cast<unsigned long long>(pv), static_cast<unsigned long long>(ps), rv, rs);
    json += (json.back() == '[' ? "" : ",") + std::string("{\"error_m\":") + std::to_string(e) +
            ",\"rtin\":" + std::to_string(r) + ",\"pbdam_vertical\":" + std::to_string(pv) +
            ",\"pbdam_stored\":" + std::to_string(ps) +
            ",\"ratio_vertical\":" + std::to_string(rv) +
            ",\"ratio_stored\":" + std::to_string(rs) + "}";
  }
  json += "]}";
  printPerLevel(lattice, depth, stored, vertical, triangles, errors);
  printLowerBounds(*manifest, depth, stored, triangles, errors,
                   [&](double e) { return cutTriangles(lattice, rtinDepth, rtin, {}, e); });
  std::printf("%s\n", json.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam_mesh_efficiency: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "pbdam_mesh_efficiency: unknown exception\n");
  }
  return 1;
}
