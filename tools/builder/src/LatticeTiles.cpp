// The stored lattice points, tile by tile (LatticeTiles.h).
#include "pbdam/builder/LatticeTiles.h"

#include <cassert>

using namespace pbdam::runtime;

namespace pbdam::builder {

LatticeTiles LatticeTiles::dense(std::uint32_t sideCells) {
  LatticeTiles tiles(sideCells, sideCells, std::vector<std::uint8_t>(6, 0));
  tiles.dense_ = true;
  return tiles;
}

LatticeTiles::LatticeTiles(std::uint32_t sideCells, std::uint32_t tileCells,
                           std::vector<std::uint8_t> spacingLog2)
    : sideCells_(sideCells),
      tileCells_(tileCells),
      tilesPerSide_(sideCells / tileCells),
      spacingLog2_(std::move(spacingLog2)) {
  assert(tileCells > 0 && sideCells % tileCells == 0);
  assert(spacingLog2_.size() == 6 * std::size_t{tilesPerSide_} * tilesPerSide_);
  offset_.assign(spacingLog2_.size() + 1, 0);
  rowStart_.assign(spacingLog2_.size() + 1, 0);
  for (std::size_t k = 0; k < spacingLog2_.size(); ++k) {
    assert((std::uint32_t{1} << spacingLog2_[k]) <= tileCells_);
    const std::uint64_t side = pointsPerRow(k);
    offset_[k + 1] = offset_[k] + side * side;
    rowStart_[k + 1] = rowStart_[k] + side;
  }
}

LatticeTiles::Row LatticeTiles::row(std::uint64_t r) const noexcept {
  assert(r < rowCount());
  // The last tile whose rows start at or before r.
  const auto it = std::upper_bound(rowStart_.begin(), rowStart_.end(), r);
  const auto tile = static_cast<std::size_t>(it - rowStart_.begin()) - 1;
  const std::size_t perFace = std::size_t{tilesPerSide_} * tilesPerSide_;
  const auto tx = static_cast<std::int32_t>(tile % tilesPerSide_);
  const auto ty = static_cast<std::int32_t>(tile % perFace / tilesPerSide_);
  const std::uint64_t j = r - rowStart_[tile];
  Row out;
  out.face = static_cast<int>(tile / perFace);
  out.spacing = spacing(tile);
  out.points = pointsPerRow(tile);
  const auto cells = static_cast<std::int32_t>(tileCells_);
  out.first = LatticeXY{tx * cells, ty * cells + static_cast<std::int32_t>(j) * out.spacing};
  out.offset = offset_[tile] + j * out.points;
  return out;
}

std::uint64_t LatticeTiles::index(int face, LatticeXY p) const noexcept {
  if (dense_) {
    const std::uint64_t n1 = std::uint64_t{sideCells_} + 1;
    return (static_cast<std::uint64_t>(face) * n1 + static_cast<std::uint64_t>(p.y)) * n1 +
           static_cast<std::uint64_t>(p.x);
  }
  // The tile of p's cell, and on a border the tiles to its left and below, which also hold it.
  const std::uint32_t txs[2] = {clampTile(p.x), below(p.x)};
  const std::uint32_t tys[2] = {clampTile(p.y), below(p.y)};
  for (const std::uint32_t ty : tys) {
    for (const std::uint32_t tx : txs) {
      const std::size_t k = tileOf(face, tx, ty);
      const std::int32_t s = spacing(k);
      if (p.x % s != 0 || p.y % s != 0) continue;
      const auto cells = static_cast<std::int32_t>(tileCells_);
      const auto i = static_cast<std::uint64_t>((p.x - static_cast<std::int32_t>(tx) * cells) / s);
      const auto j = static_cast<std::uint64_t>((p.y - static_cast<std::int32_t>(ty) * cells) / s);
      return offset_[k] + j * pointsPerRow(k) + i;
    }
  }
  return kAbsent;
}

}  // namespace pbdam::builder
