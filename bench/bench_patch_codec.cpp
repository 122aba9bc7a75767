// Micro-benchmarks of the patch codec ([P-BDAM 2003] §4.4: LZO-compressed patches decoded while
// paging): decode throughput in triangles/s and decoded bytes/s, encode time for lzo1x_1
// (PatchCompression::Fast) and lzo1x_999 (Compact), and the compression ratio as a counter.
// Run: build/release/bench/pbdam_bench_patch_codec
#include <benchmark/benchmark.h>
#include <meshoptimizer.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "SyntheticPatches.h"
#include "pbdam/formats/GuardedCopy.h"
#include "pbdam/formats/PatchCodec.h"

using namespace pbdam::formats;

namespace {

using pbdam::formats::PatchCompression;
using pbdam::formats::PatchMesh;

// ---- realistic patches (tests/support/SyntheticPatches.h, shared with the codec tests) -------

PatchMesh optimizedGrid(unsigned cells, unsigned seed) {
  PatchMesh mesh = pbdam::test::gridPatch(cells, seed);
  pbdam::formats::optimizePatchForRendering(mesh);
  return mesh;
}

// 0: 32-cell leaf grid (561 vertices, 1024 triangles); 1, 2: simplified (~520 v, ~1000 t).
const std::vector<PatchMesh>& patches() {
  static const std::vector<PatchMesh> all = {optimizedGrid(32, 1),
                                             pbdam::test::simplifiedPatch(128, 1000, 2),
                                             pbdam::test::simplifiedPatch(256, 1000, 3)};
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
  const std::vector<std::byte> blob = pbdam::formats::encodePatch(mesh, compression).value();
  PatchMesh out;
  for (auto _ : state) {
    const pbdam::formats::Result<void> r = pbdam::formats::decodePatch(blob, out, "bench");
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
    auto blob = pbdam::formats::encodePatch(mesh, compression);
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

/// What every decode of a mapped blob is now preceded by: the blob copied out of the mapping,
/// plainly (memcpy, arg 0) or through the SIGBUS guard (guardedCopy, arg 1), for blob sizes of
/// 1, 4 and 16 KiB (patch blobs are a few KiB; tiles up to 16 KiB compressed).
void BM_CopyBlobOutOfMapping(benchmark::State& state) {
  const auto bytes = static_cast<std::size_t>(state.range(0));
  const bool guarded = state.range(1) != 0;
  std::vector<std::byte> source(bytes, std::byte{7});
  std::vector<std::byte> destination(bytes);
  for (auto _ : state) {
    if (guarded) {
      benchmark::DoNotOptimize(
          pbdam::formats::guardedCopy(destination.data(), source.data(), bytes).has_value());
    } else {
      std::memcpy(destination.data(), source.data(), bytes);
    }
    benchmark::ClobberMemory();
  }
  state.SetLabel(guarded ? "guardedCopy" : "memcpy");
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(bytes));
}
BENCHMARK(BM_CopyBlobOutOfMapping)->ArgsProduct({{1024, 4096, 16384}, {0, 1}});

void BM_OptimizePatchForRendering(benchmark::State& state) {
  const PatchMesh& mesh = patches()[static_cast<std::size_t>(state.range(0))];
  for (auto _ : state) {
    PatchMesh copy = mesh;
    pbdam::formats::optimizePatchForRendering(copy);
    benchmark::DoNotOptimize(copy.indices.data());
  }
  state.SetLabel(patchName(state.range(0)));
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(mesh.triangleCount()));
}
BENCHMARK(BM_OptimizePatchForRendering)->DenseRange(0, 2);

}  // namespace

BENCHMARK_MAIN();
