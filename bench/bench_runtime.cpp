// Runtime micro-benchmarks (docs/architecture.md "Refinement and drawing", "Streaming"): the
// stateless refinement traversal of [P-BDAM 2003] §4.3 over the poses of a recorded flight (µs per
// frame), the decode of patches into GPU vertices (DecodeScheduler: LZO, then each vertex's
// terrain point and offset in double; one thread), and the GPU cache's LRU bookkeeping
// (ResidencyLru: touch, insert with eviction). Google
// Benchmark; the traversal reads a built dataset: PBDAM_BENCH_DATASET (default build/testdata/mola,
// which the test suite's fixture builds) and the flight PBDAM_BENCH_PATH (default
// bench/paths/mars_flight.csv).
//   build/release/bench/pbdam_bench_runtime [--benchmark_filter=...]
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "pbdam/formats/CameraPath.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/CutReuse.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/DecodeScheduler.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/ResidencyLru.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace {

using namespace pbdam;

std::string envOr(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0' ? std::string(v) : fallback;
}

struct Flight {
  std::unique_ptr<MappedDataset> dataset;
  std::vector<Camera> cameras;
  std::string error;
};

const Flight& flight() {
  static const Flight f = [] {
    Flight out;
    const std::string dir = envOr("PBDAM_BENCH_DATASET", PBDAM_SOURCE_DIR "/build/testdata/mola");
    const std::string pathFile =
        envOr("PBDAM_BENCH_PATH", PBDAM_SOURCE_DIR "/bench/paths/mars_flight.csv");
    auto dataset = MappedDataset::open(dir);
    if (!dataset) {
      out.error = dataset.error().message;
      return out;
    }
    auto path = readCameraPath(pathFile);
    if (!path) {
      out.error = path.error().message;
      return out;
    }
    out.dataset = std::move(dataset).value();
    const Viewport viewport{640, 480, 60.0};
    for (const CameraPathPoint& p : *path) {
      out.cameras.push_back(Camera::fromPose(out.dataset->view().planet(),
                                             {p.latDegrees, p.lonDegrees, p.altitudeMeters,
                                              p.headingDegrees, p.pitchDegrees, p.rollDegrees},
                                             viewport));
    }
    return out;
  }();
  return f;
}

// One refinement per iteration, cycling through the flight's poses (640×480, 3 px).
void BM_RefineFlightFrame(benchmark::State& state) {
  const Flight& f = flight();
  if (!f.error.empty()) {
    state.SkipWithError(f.error.c_str());
    return;
  }
  RefinementOptions options;
  options.tolerancePixels = 3.0;
  std::size_t frame = 0;
  std::uint64_t patches = 0;
  for (auto _ : state) {
    const Cut cut = refine(f.dataset->view(), f.cameras[frame], options);
    patches += cut.patches.size();
    benchmark::DoNotOptimize(cut.patches.data());
    frame = (frame + 1) % f.cameras.size();
  }
  state.counters["patches/frame"] =
      benchmark::Counter(static_cast<double>(patches), benchmark::Counter::kAvgIterations);
  state.SetLabel(std::to_string(f.cameras.size()) + " poses");
}
BENCHMARK(BM_RefineFlightFrame)->Unit(benchmark::kMicrosecond);

// The same flight with the refinement tree kept from frame to frame (IncrementalRefiner: the
// same cuts): time per frame, and split/cull decisions per frame against the stateless ones.
void BM_IncrementalFlightFrame(benchmark::State& state) {
  const Flight& f = flight();
  if (!f.error.empty()) {
    state.SkipWithError(f.error.c_str());
    return;
  }
  RefinementOptions options;
  options.tolerancePixels = 3.0;
  std::size_t frame = 0;
  std::uint64_t decisions = 0;
  std::uint64_t stateless = 0;
  std::uint64_t frames = 0;
  std::optional<IncrementalRefiner> incremental;
  for (auto _ : state) {
    if (frame == 0) incremental.emplace(f.dataset->view());  // each pass starts cold
    const Cut cut = incremental->update(f.cameras[frame], options);
    decisions += incremental->lastStats().decisions;
    benchmark::DoNotOptimize(cut.patches.data());
    state.PauseTiming();
    stateless += refine(f.dataset->view(), f.cameras[frame], options).nodesVisited;
    state.ResumeTiming();
    ++frames;
    frame = (frame + 1) % f.cameras.size();
  }
  state.counters["decisions/frame"] =
      benchmark::Counter(static_cast<double>(decisions), benchmark::Counter::kAvgIterations);
  state.counters["stateless/frame"] =
      benchmark::Counter(static_cast<double>(stateless), benchmark::Counter::kAvgIterations);
  state.SetLabel(std::to_string(f.cameras.size()) + " poses");
}
BENCHMARK(BM_IncrementalFlightFrame)->Unit(benchmark::kMicrosecond);

// Every leaf patch of the dataset decoded into the GPU cache's layout (vertices, then indices)
// on one thread, as a cache miss does: LZO and the byte planes, then the GPU vertex of each
// vertex. Items: triangles.
void BM_DecodeLeafPatchesToGpu(benchmark::State& state) {
  const Flight& f = flight();
  if (!f.error.empty()) {
    state.SkipWithError(f.error.c_str());
    return;
  }
  const tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
  const DatasetView& view = f.dataset->view();
  const DecodeScheduler decoder(view, TexelFormat::Rgba8);
  std::vector<DecodeJob> jobs;
  std::uint64_t triangles = 0;
  for (std::uint8_t face = 0; face < 6; ++face) {
    const FaceView& file = view.face(face);
    for (std::uint64_t row = 0; row < file.header().nodeCount; ++row) {
      const NodeRecord n = file.nodeAt(row);
      if (!n.leaf()) continue;
      const auto tree = static_cast<std::uint8_t>(row >= file.treeFirstNode(1) ? 1 : 0);
      const NodeKey key{face, tree, n.heapIndex};
      DecodeJob job;
      job.key = ResidentKey::patch(key);
      job.node = key;
      jobs.push_back(job);
      triangles += n.triangleCount;
    }
  }
  std::vector<std::byte> out(decoder.layout(jobs));
  for (auto _ : state) {
    const auto r = decoder.decode(jobs, out);
    if (!r) {
      state.SkipWithError(r.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(triangles) * state.iterations());
  state.SetLabel(std::to_string(jobs.size()) + " patches");
}
BENCHMARK(BM_DecodeLeafPatchesToGpu)->Unit(benchmark::kMillisecond);

// A frame's worth of cache traffic: `range(0)` keys per frame from a window that slides by a
// quarter of itself each frame, under a budget of two frames' entries — so every frame touches
// 3/4 of its keys and inserts the rest, evicting the least recently used once the cache is full.
void BM_LruFrame(benchmark::State& state) {
  const auto perFrame = static_cast<std::uint64_t>(state.range(0));
  constexpr std::uint64_t kSlot = 4096;
  ResidencyLru lru(2 * perFrame * kSlot, {kSlot, kSlot});
  std::vector<ResidentKey> evicted;
  std::uint64_t epoch = 0;
  std::uint64_t first = 0;
  std::uint64_t operations = 0;
  for (auto _ : state) {
    ++epoch;
    evicted.clear();
    for (std::uint64_t k = first; k < first + perFrame; ++k) {
      const ResidentKey key = ResidentKey::patch(
          NodeKey{static_cast<std::uint8_t>(k % 6), static_cast<std::uint8_t>(k / 6 % 2), k});
      if (lru.find(key)) {
        lru.touch(key, epoch);
      } else {
        benchmark::DoNotOptimize(lru.insert(key, epoch, evicted));
      }
    }
    operations += perFrame;
    first += perFrame / 4;
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(operations));
}
BENCHMARK(BM_LruFrame)->Arg(256)->Arg(4096);

}  // namespace

BENCHMARK_MAIN();
