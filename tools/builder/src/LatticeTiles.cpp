// The stored lattice points, tile by tile (LatticeTiles.h).
#include "pbdam/builder/LatticeTiles.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <functional>

using namespace pbdam::runtime;

namespace pbdam::builder {

LatticeTiles LatticeTiles::dense(std::uint32_t sideCells) {
  LatticeTiles tiles(sideCells, sideCells, std::vector<std::uint8_t>(6, 0));
  tiles.dense_ = true;
  return tiles;
}

LatticeTiles::LatticeTiles(std::uint32_t sideCells, std::uint32_t tileCells,
                           std::vector<std::uint8_t> spacingLog2)
    : sideCells_(sideCells), tileCells_(tileCells), tilesPerSide_(sideCells / tileCells) {
  assert(tileCells > 0 && sideCells % tileCells == 0);
  assert(spacingLog2.size() == 6 * std::size_t{tilesPerSide_} * tilesPerSide_);
  tiles_.reserve(spacingLog2.size());
  nodes_.reserve(spacingLog2.size());
  for (std::size_t k = 0; k < spacingLog2.size(); ++k) {
    assert((std::uint32_t{1} << spacingLog2[k]) <= tileCells_);
    const std::size_t perFace = std::size_t{tilesPerSide_} * tilesPerSide_;
    const auto tx = static_cast<std::int32_t>(k % tilesPerSide_);
    const auto ty = static_cast<std::int32_t>(k % perFace / tilesPerSide_);
    const auto cells = static_cast<std::int32_t>(tileCells_);
    tiles_.push_back(Tile{tx * cells, ty * cells, tileCells_,
                          static_cast<std::uint8_t>(k / perFace), spacingLog2[k]});
    nodes_.push_back(-static_cast<std::int64_t>(k) - 1);
  }
  finishLayout();
}

LatticeTiles LatticeTiles::adaptive(std::uint32_t sideCells, std::uint32_t tileCells,
                                    std::uint8_t baseSpacingLog2, std::span<const Region> regions,
                                    std::uint32_t maxPointsPerSide) {
  assert(tileCells > 0 && sideCells % tileCells == 0);
  LatticeTiles out;
  out.sideCells_ = sideCells;
  out.tileCells_ = tileCells;
  out.tilesPerSide_ = sideCells / tileCells;
  const std::size_t squares = 6 * std::size_t{out.tilesPerSide_} * out.tilesPerSide_;
  out.nodes_.assign(squares, 0);
  // Regions by face, then each square is cut while it is finer than maxPointsPerSide allows,
  // with the regions that share area with it handed down.
  std::array<std::vector<Region>, 6> byFace;
  for (const Region& r : regions) byFace[static_cast<std::size_t>(r.face)].push_back(r);
  const auto shares = [](const Region& r, std::int64_t x, std::int64_t y, std::int64_t cells) {
    return r.x0 < x + cells && r.x1 > x && r.y0 < y + cells && r.y1 > y;
  };
  const std::function<std::int64_t(int, std::int64_t, std::int64_t, std::uint32_t,
                                   std::span<const Region>)>
      build = [&](int face, std::int64_t x, std::int64_t y, std::uint32_t cells,
                  std::span<const Region> parent) -> std::int64_t {
    std::vector<Region> mine;
    std::uint8_t finest = baseSpacingLog2;
    for (const Region& r : parent) {
      if (!shares(r, x, y, cells)) continue;
      mine.push_back(r);
      finest = std::min(finest, r.spacingLog2);
    }
    finest = std::min<std::uint8_t>(
        finest, static_cast<std::uint8_t>(std::countr_zero(cells)));  // at most the square
    if ((cells >> finest) <= maxPointsPerSide || cells <= (std::uint32_t{1} << finest) ||
        mine.empty()) {
      out.tiles_.push_back(Tile{static_cast<std::int32_t>(x), static_cast<std::int32_t>(y), cells,
                                static_cast<std::uint8_t>(face), finest});
      return -static_cast<std::int64_t>(out.tiles_.size());
    }
    const auto first = static_cast<std::int64_t>(out.nodes_.size());
    out.nodes_.resize(out.nodes_.size() + 4);
    const std::uint32_t half = cells / 2;
    for (std::int64_t q = 0; q < 4; ++q) {
      const std::int64_t child = build(face, x + (q & 1) * half, y + (q >> 1) * half, half, mine);
      out.nodes_[static_cast<std::size_t>(first + q)] = child;
    }
    return first;
  };
  for (std::size_t k = 0; k < squares; ++k) {
    const std::size_t perFace = std::size_t{out.tilesPerSide_} * out.tilesPerSide_;
    const auto face = static_cast<int>(k / perFace);
    const std::int64_t x = static_cast<std::int64_t>(k % out.tilesPerSide_) * tileCells;
    const std::int64_t y = static_cast<std::int64_t>(k % perFace / out.tilesPerSide_) * tileCells;
    const std::int64_t node = build(face, x, y, tileCells, byFace[static_cast<std::size_t>(face)]);
    out.nodes_[k] = node;
  }
  out.finishLayout();
  return out;
}

void LatticeTiles::finishLayout() {
  offset_.assign(tiles_.size() + 1, 0);
  rowStart_.assign(tiles_.size() + 1, 0);
  for (std::size_t k = 0; k < tiles_.size(); ++k) {
    const std::uint64_t side = tiles_[k].pointsPerRow();
    offset_[k + 1] = offset_[k] + side * side;
    rowStart_[k + 1] = rowStart_[k] + side;
  }
}

LatticeTiles::Row LatticeTiles::row(std::uint64_t r) const noexcept {
  assert(r < rowCount());
  // The last tile whose rows start at or before r.
  const auto it = std::upper_bound(rowStart_.begin(), rowStart_.end(), r);
  const auto k = static_cast<std::size_t>(it - rowStart_.begin()) - 1;
  const Tile& t = tiles_[k];
  const std::uint64_t j = r - rowStart_[k];
  Row out;
  out.face = t.face;
  out.spacing = t.spacing();
  out.points = t.pointsPerRow();
  out.first = LatticeXY{t.x0, t.y0 + static_cast<std::int32_t>(j) * out.spacing};
  out.offset = offset_[k] + j * out.points;
  return out;
}

std::uint64_t LatticeTiles::index(int face, LatticeXY p) const noexcept {
  if (dense_) {
    const std::uint64_t n1 = std::uint64_t{sideCells_} + 1;
    return (static_cast<std::uint64_t>(face) * n1 + static_cast<std::uint64_t>(p.y)) * n1 +
           static_cast<std::uint64_t>(p.x);
  }
  // The tile of p's cell, and on a border the tiles of the cells to its left and below, which
  // also hold it.
  const std::int32_t xs[2] = {clampCell(p.x), std::max(p.x - 1, 0)};
  const std::int32_t ys[2] = {clampCell(p.y), std::max(p.y - 1, 0)};
  for (const std::int32_t cy : ys) {
    for (const std::int32_t cx : xs) {
      const std::size_t k = tileOfCell(face, cx, cy);
      const Tile& t = tiles_[k];
      const std::int32_t s = t.spacing();
      const auto cells = static_cast<std::int32_t>(t.cells);
      if (p.x < t.x0 || p.x > t.x0 + cells || p.y < t.y0 || p.y > t.y0 + cells) continue;
      if (p.x % s != 0 || p.y % s != 0) continue;
      const auto i = static_cast<std::uint64_t>((p.x - t.x0) / s);
      const auto j = static_cast<std::uint64_t>((p.y - t.y0) / s);
      return offset_[k] + j * t.pointsPerRow() + i;
    }
  }
  return kAbsent;
}

}  // namespace pbdam::builder
