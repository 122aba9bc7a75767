// libFuzzer target for the builder's greedy insertion (tools/builder/src/GreedyInsertion.h) on
// degenerate height fields: the input picks a 16-cell lattice's heights (flat runs, spikes,
// cliffs, slopes up to ±2^24 m per cell, repeated values), one of eight bintree triangles (axis
// and diagonal legs), which of its edge points are locked, the target, the triangle floor and the
// vertex cap. Whatever comes out must tile the triangle with counter-clockwise triangles, keep
// every locked point and every corner, respect the cap, and meet the target unless the cap
// stopped it; the 1-D segment insertion must keep its ends and meet its target.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "GreedyInsertion.h"

using pbdam::builder::ChordModel;
using pbdam::builder::doubleArea;
using pbdam::builder::FaceHeights;
using pbdam::builder::InsertionLimits;
using pbdam::runtime::LatticeXY;

namespace {

constexpr int kCells = 16;

void check(bool condition) {
  if (!condition) std::abort();
}

/// Reads the input front to back; zeros once it runs out.
class Bytes {
 public:
  explicit Bytes(std::span<const std::uint8_t> data) : data_(data) {}
  std::uint8_t next() { return at_ < data_.size() ? data_[at_++] : 0; }

 private:
  std::span<const std::uint8_t> data_;
  std::size_t at_ = 0;
};

std::vector<float> heightsFrom(Bytes& in) {
  std::vector<float> h(static_cast<std::size_t>((kCells + 1) * (kCells + 1)));
  const int mode = in.next() % 4;
  for (std::size_t k = 0; k < h.size(); ++k) {
    const auto b = static_cast<std::int8_t>(in.next());
    const auto x = static_cast<float>(k % (kCells + 1));
    switch (mode) {
      case 0:  // small relief with flat runs
        h[k] = static_cast<float>(b / 16) * 10.0f;
        break;
      case 1:  // spikes and cliffs
        h[k] = b > 100 ? 8848.0f : (b < -100 ? -11000.0f : 0.0f);
        break;
      case 2:  // an extreme slope plus noise
        h[k] = x * 16777216.0f + static_cast<float>(b);
        break;
      default:  // raw bytes, huge scale
        h[k] = static_cast<float>(b) * 1.0e5f;
        break;
    }
  }
  return h;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in(std::span<const std::uint8_t>(data, size));
  const std::vector<float> heights = heightsFrom(in);
  const FaceHeights field{heights.data(), kCells};
  constexpr int n = kCells;
  constexpr int m = kCells / 2;
  const std::array<std::array<LatticeXY, 3>, 8> shapes = {{
      {LatticeXY{0, 0}, LatticeXY{0, n}, LatticeXY{n, 0}},
      {LatticeXY{n, n}, LatticeXY{n, 0}, LatticeXY{0, n}},
      {LatticeXY{n, 0}, LatticeXY{0, 0}, LatticeXY{n, n}},
      {LatticeXY{0, n}, LatticeXY{n, n}, LatticeXY{0, 0}},
      {LatticeXY{m, m}, LatticeXY{0, 0}, LatticeXY{n, 0}},
      {LatticeXY{m, m}, LatticeXY{n, 0}, LatticeXY{n, n}},
      {LatticeXY{m, m}, LatticeXY{n, n}, LatticeXY{0, n}},
      {LatticeXY{m, 0}, LatticeXY{0, 0}, LatticeXY{m, m}},
  }};
  const auto& corners = shapes[in.next() % shapes.size()];
  // Locked points: each edge point of the triangle with probability 1/2 (by input bits).
  std::vector<LatticeXY> locked;
  for (std::size_t e = 0; e < 3; ++e) {
    const LatticeXY a = corners[e];
    const LatticeXY d = corners[(e + 1) % 3] - a;
    const int steps = std::max(std::abs(d.x), std::abs(d.y));
    for (int k = 1; k < steps; ++k) {
      if (in.next() & 1) locked.push_back(a + d / steps * k);
    }
  }
  const double target = static_cast<double>(in.next()) * static_cast<double>(in.next());
  const auto minTriangles = static_cast<std::uint32_t>(in.next());
  const std::uint32_t maxVertices = 3 + in.next();
  const ChordModel chord = (in.next() & 1) ? ChordModel{1000.0, 3.4e6} : ChordModel{};

  const auto r = pbdam::builder::insertGreedily(
      field, corners, locked, InsertionLimits{target, minTriangles, maxVertices}, chord);
  const auto& p = r.patch;
  check(p.indices.size() % 3 == 0);
  check(p.points.size() <= std::max<std::size_t>(maxVertices, 3 + locked.size()));
  std::int64_t area = 0;
  for (std::size_t k = 0; k < p.indices.size(); k += 3) {
    for (std::size_t j = 0; j < 3; ++j) check(p.indices[k + j] < p.points.size());
    const std::int64_t a =
        doubleArea(p.points[p.indices[k]], p.points[p.indices[k + 1]], p.points[p.indices[k + 2]]);
    check(a > 0);
    area += a;
  }
  check(area == std::abs(doubleArea(corners[0], corners[1], corners[2])));
  for (const LatticeXY q : locked) {
    check(std::find(p.points.begin(), p.points.end(), q) != p.points.end());
  }
  for (const LatticeXY q : corners) {
    check(std::find(p.points.begin(), p.points.end(), q) != p.points.end());
  }
  const bool capped = p.points.size() >= maxVertices;
  check(capped || r.maxErrorMeters <= target || r.maxErrorMeters == 0.0 || std::isnan(target));

  // The segment version along the first edge.
  std::vector<double> line(static_cast<std::size_t>(n) + 1);
  for (std::size_t k = 0; k < line.size(); ++k) line[k] = static_cast<double>(heights[k]);
  const auto kept = pbdam::builder::insertAlongSegment(line, 1.0, target, chord);
  check(kept.size() >= 2 && kept.front() == 0 && kept.back() == line.size() - 1);
  check(std::is_sorted(kept.begin(), kept.end()));
  return 0;
}
