// Micro-benchmarks of elevation ingest: reading ETOPO5 through GDAL and sampling the grid
// bilinearly/bicubically at random points (the builder's resampling kernel).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "pbdam/formats/DemReader.h"

namespace {

const char* kEtopo5 = "/usr/share/ferret-vis/data/etopo5.cdf";

const pbdam::formats::HeightGrid& etopo5() {
  static const pbdam::formats::HeightGrid grid = [] {
    auto r = pbdam::formats::readDem(kEtopo5);
    return r ? std::move(r).value() : pbdam::formats::HeightGrid();
  }();
  return grid;
}

std::vector<std::pair<double, double>> randomPoints(std::size_t n) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> lat(-90.0, 90.0);
  std::uniform_real_distribution<double> lon(-180.0, 360.0);
  std::vector<std::pair<double, double>> points(n);
  for (auto& p : points) p = {lat(rng), lon(rng)};
  return points;
}

void BM_ReadEtopo5(benchmark::State& state) {
  for (auto _ : state) {
    auto grid = pbdam::formats::readDem(kEtopo5);
    if (!grid) {
      state.SkipWithError(grid.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(grid->heightsMeters().data());
    state.SetBytesProcessed(state.bytes_processed() +
                            static_cast<std::int64_t>(grid->heightsMeters().size() * 4));
  }
}
BENCHMARK(BM_ReadEtopo5)->Unit(benchmark::kMillisecond);

template <bool kBicubic>
void BM_Sample(benchmark::State& state) {
  const auto& grid = etopo5();
  if (grid.width() == 0) {
    state.SkipWithError("ETOPO5 not found (scripts/setup.sh installs ferret-datasets)");
    return;
  }
  const auto points = randomPoints(1 << 16);
  std::size_t k = 0;
  for (auto _ : state) {
    const auto& p = points[k++ & (points.size() - 1)];
    benchmark::DoNotOptimize(kBicubic ? grid.sampleBicubic(p.first, p.second)
                                      : grid.sampleBilinear(p.first, p.second));
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_Sample<false>)->Name("BM_SampleBilinear");
BENCHMARK(BM_Sample<true>)->Name("BM_SampleBicubic");

}  // namespace

BENCHMARK_MAIN();
