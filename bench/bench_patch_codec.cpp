// Micro-benchmarks of the patch codec (paper 004 §4.4: LZO-compressed patches decoded while
// paging): decode throughput in triangles/s and decoded bytes/s, encode time for lzo1x_1
// (PatchCompression::Fast) and lzo1x_999 (Compact), and the compression ratio as a counter.
// Run: build/release/bench/pbdam_bench_patch_codec
#include <benchmark/benchmark.h>
#include <meshoptimizer.h>

#include <cmath>
#include <random>
#include <vector>

#include "pbdam/formats/PatchCodec.h"

namespace {

using pbdam::PatchCompression;
using pbdam::PatchMesh;
using pbdam::PatchVertex;

// ---- realistic patches (the same generators as tests/formats/TestPatchCodec.cpp) -------------

double terrainMeters(double x, double y, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0.0, 6.283185307179586);
  double h = 0.0;
  double amplitude = 400.0;
  double frequency = 1.5;
  for (int octave = 0; octave < 8; ++octave) {
    const double px = phase(rng);
    const double py = phase(rng);
    h += amplitude * std::sin(frequency * 6.283 * x + px) * std::cos(frequency * 5.65 * y + py);
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return h;
}

// Leaf patch: regular right-triangulated grid, legs of `cells` cells, heights in 1/64 m steps.
PatchMesh gridPatch(unsigned cells, unsigned seed, double noiseMeters = 1.0) {
  std::mt19937 rng(seed * 7 + 1);
  std::uniform_real_distribution<double> noise(-noiseMeters, noiseMeters);
  PatchMesh mesh;
  std::vector<unsigned> id((cells + 1) * (cells + 1));
  for (unsigned j = 0; j <= cells; ++j) {
    for (unsigned i = 0; i + j <= cells; ++i) {
      id[j * (cells + 1) + i] = static_cast<unsigned>(mesh.vertices.size());
      const double h = terrainMeters(i / double(cells), j / double(cells), seed) + noise(rng);
      mesh.vertices.push_back(PatchVertex{static_cast<std::uint16_t>(i * 32768U / cells),
                                          static_cast<std::uint16_t>(j * 32768U / cells),
                                          static_cast<std::int32_t>(std::lround(h * 64.0))});
    }
  }
  auto at = [&](unsigned i, unsigned j) {
    return static_cast<std::uint16_t>(id[j * (cells + 1) + i]);
  };
  for (unsigned j = 0; j < cells; ++j) {
    for (unsigned i = 0; i + j < cells; ++i) {
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i, j + 1)});
      if (i + j + 1 < cells) {
        mesh.indices.insert(mesh.indices.end(), {at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
  }
  pbdam::optimizePatchForRendering(mesh);
  return mesh;
}

// Upper-level patch: a fine grid simplified by meshopt_simplify to about `triangles` triangles.
PatchMesh simplifiedPatch(unsigned fineCells, std::size_t triangles, unsigned seed) {
  const PatchMesh fine = gridPatch(fineCells, seed, 0.5);
  std::vector<float> positions(fine.vertices.size() * 3);
  const double cellMeters = 400.0;
  for (std::size_t i = 0; i < fine.vertices.size(); ++i) {
    positions[3 * i] = static_cast<float>(fine.vertices[i].b1 / 32768.0 * fineCells * cellMeters);
    positions[3 * i + 1] =
        static_cast<float>(fine.vertices[i].b2 / 32768.0 * fineCells * cellMeters);
    positions[3 * i + 2] = static_cast<float>(fine.vertices[i].heightSteps / 64.0);
  }
  std::vector<std::uint16_t> simplified(fine.indices.size());
  const std::size_t count = meshopt_simplify(
      simplified.data(), fine.indices.data(), fine.indices.size(), positions.data(),
      fine.vertices.size(), 3 * sizeof(float), triangles * 3, 1.0f, 0, nullptr);
  PatchMesh mesh;
  mesh.vertices = fine.vertices;
  mesh.indices.assign(simplified.begin(), simplified.begin() + static_cast<std::ptrdiff_t>(count));
  pbdam::optimizePatchForRendering(mesh);
  return mesh;
}

// 0: 32-cell leaf grid (561 vertices, 1024 triangles); 1, 2: simplified (~520 v, ~1000 t).
const std::vector<PatchMesh>& patches() {
  static const std::vector<PatchMesh> all = {gridPatch(32, 1), simplifiedPatch(128, 1000, 2),
                                             simplifiedPatch(256, 1000, 3)};
  return all;
}

const char* patchName(std::int64_t i) {
  static const char* names[] = {"grid32", "simplified128", "simplified256"};
  return names[i];
}

// Size of the decoded mesh in memory (and of the plain representation the ratio refers to).
std::size_t decodedBytes(const PatchMesh& mesh) {
  return 8 * mesh.vertices.size() + 6 * mesh.triangleCount();
}

void setCounters(benchmark::State& state, const PatchMesh& mesh, std::size_t blobBytes) {
  state.counters["vertices"] = static_cast<double>(mesh.vertices.size());
  state.counters["triangles"] = static_cast<double>(mesh.triangleCount());
  state.counters["ratio"] =
      static_cast<double>(decodedBytes(mesh)) / static_cast<double>(blobBytes);
  state.counters["blob_bytes"] = static_cast<double>(blobBytes);
}

void BM_DecodePatch(benchmark::State& state) {
  const PatchMesh& mesh = patches()[static_cast<std::size_t>(state.range(0))];
  const auto compression = static_cast<PatchCompression>(state.range(1));
  const std::vector<std::byte> blob = pbdam::encodePatch(mesh, compression).value();
  PatchMesh out;
  for (auto _ : state) {
    const pbdam::Result<void> r = pbdam::decodePatch(blob, out, "bench");
    benchmark::DoNotOptimize(r.ok());
    benchmark::DoNotOptimize(out.indices.data());
    benchmark::ClobberMemory();
  }
  if (out != mesh) state.SkipWithError("decoded patch differs");
  state.SetLabel(std::string(patchName(state.range(0))) +
                 (compression == PatchCompression::Fast ? "/lzo1x_1" : "/lzo1x_999"));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(mesh.triangleCount()));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(decodedBytes(mesh)));
  setCounters(state, mesh, blob.size());
}

void BM_EncodePatch(benchmark::State& state) {
  const PatchMesh& mesh = patches()[static_cast<std::size_t>(state.range(0))];
  const auto compression = static_cast<PatchCompression>(state.range(1));
  std::size_t blobBytes = 0;
  for (auto _ : state) {
    auto blob = pbdam::encodePatch(mesh, compression);
    blobBytes = blob->size();
    benchmark::DoNotOptimize(blob->data());
  }
  state.SetLabel(std::string(patchName(state.range(0))) +
                 (compression == PatchCompression::Fast ? "/lzo1x_1" : "/lzo1x_999"));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(mesh.triangleCount()));
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(decodedBytes(mesh)));
  setCounters(state, mesh, blobBytes);
}

void patchArgs(benchmark::internal::Benchmark* b) {
  for (std::int64_t patch = 0; patch < 3; ++patch) {
    for (auto compression : {PatchCompression::Fast, PatchCompression::Compact}) {
      b->Args({patch, static_cast<std::int64_t>(compression)});
    }
  }
}

BENCHMARK(BM_DecodePatch)->Apply(patchArgs);
BENCHMARK(BM_EncodePatch)->Apply(patchArgs);

void BM_OptimizePatchForRendering(benchmark::State& state) {
  const PatchMesh& mesh = patches()[static_cast<std::size_t>(state.range(0))];
  for (auto _ : state) {
    PatchMesh copy = mesh;
    pbdam::optimizePatchForRendering(copy);
    benchmark::DoNotOptimize(copy.indices.data());
  }
  state.SetLabel(patchName(state.range(0)));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(mesh.triangleCount()));
}
BENCHMARK(BM_OptimizePatchForRendering)->DenseRange(0, 2);

}  // namespace

BENCHMARK_MAIN();
