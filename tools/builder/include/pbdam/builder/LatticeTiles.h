// Which lattice points a build stores heights for (docs/builder.md "Insets: the sparse
// lattice"). A uniform build stores every point of every face. An adaptive forest goes deep only
// where an inset is, so its lattice is cut into square tiles, each stored at the spacing of the
// finest leaves inside it: a tile of spacing s holds the points of its square (borders included)
// whose coordinates are multiples of s. A point on a border between tiles of different spacings
// is stored by each tile whose grid holds it; its value is the same in each (it is one point of
// one surface). Thread-safety: immutable after construction.
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "pbdam/runtime/Bintree.h"

namespace pbdam::builder {

class LatticeTiles final {
 public:
  /// index() of a point no tile stores.
  static constexpr std::uint64_t kAbsent = std::numeric_limits<std::uint64_t>::max();

  /// Every point of every face of an N-cell lattice: one tile per face at spacing 1, stored as
  /// (N + 1)² heights row-major by j, face after face.
  static LatticeTiles dense(std::uint32_t sideCells);
  /// Squares of `tileCells` cells (a power of two dividing N), tile k at spacing
  /// 2^spacingLog2[k] ≤ tileCells; k = (face · tilesPerSide + ty) · tilesPerSide + tx.
  LatticeTiles(std::uint32_t sideCells, std::uint32_t tileCells,
               std::vector<std::uint8_t> spacingLog2);

  std::uint32_t sideCells() const noexcept { return sideCells_; }
  std::uint32_t tileCells() const noexcept { return tileCells_; }
  std::uint32_t tilesPerSide() const noexcept { return tilesPerSide_; }
  std::size_t tileCount() const noexcept { return spacingLog2_.size(); }
  /// Whether this is the dense layout (every point, one tile per face).
  bool isDense() const noexcept { return dense_; }

  std::int32_t spacing(std::size_t tile) const noexcept {
    return std::int32_t{1} << spacingLog2_[tile];
  }
  /// Points per row (and rows) of a tile: tileCells / spacing + 1.
  std::uint32_t pointsPerRow(std::size_t tile) const noexcept {
    return (tileCells_ >> spacingLog2_[tile]) + 1;
  }
  /// Where tile k's heights start (in heights, not bytes), and the total.
  std::uint64_t offset(std::size_t tile) const noexcept { return offset_[tile]; }
  std::uint64_t pointCount() const noexcept { return offset_.back(); }

  /// The storage rows: tile after tile, each tile's rows by j. The dense layout's row r is row
  /// r mod (N + 1) of face r / (N + 1).
  std::uint64_t rowCount() const noexcept { return rowStart_.back(); }
  struct Row final {
    int face = 0;
    runtime::LatticeXY first{0};  ///< its first point; the others follow `spacing` apart in x
    std::int32_t spacing = 1;
    std::uint32_t points = 0;
    std::uint64_t offset = 0;  ///< where its heights start
  };
  Row row(std::uint64_t r) const noexcept;

  /// Where point p of `face` is stored, or kAbsent if no tile holds it.
  std::uint64_t index(int face, runtime::LatticeXY p) const noexcept;

  /// The spacing of the tile whose square holds point p's cell (the tile at ⌊p / tileCells⌋,
  /// clamped at the face's far edges).
  std::int32_t spacingAt(int face, runtime::LatticeXY p) const noexcept {
    return spacing(tileOf(face, clampTile(p.x), clampTile(p.y)));
  }

  /// The finest spacing of the tiles whose squares meet the closed box [x0, x1] × [y0, y1] of
  /// `face`: every stored point of the box lies on rows (and columns) that are multiples of it.
  std::int32_t finestSpacingIn(int face, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                               std::int32_t y1) const noexcept {
    if (dense_) return 1;
    std::uint8_t finest = 255;
    for (std::uint32_t ty = below(y0); ty <= clampTile(y1); ++ty) {
      for (std::uint32_t tx = below(x0); tx <= clampTile(x1); ++tx) {
        finest = std::min(finest, spacingLog2_[tileOf(face, tx, ty)]);
      }
    }
    return std::int32_t{1} << finest;
  }

  /// One tile's stored grid, read directly: the point (x, y) of the tile at index
  /// offset + ((y − y0) / spacing) · pointsPerRow + (x − x0) / spacing.
  struct Window final {
    std::int64_t x0 = 0, y0 = 0;  ///< the tile's lower corner
    std::int32_t spacing = 1;
    std::uint64_t offset = 0;
    std::uint64_t pointsPerRow = 0;
    /// The height of point (x, y) in `data` (the storage of these tiles); (x, y) must be a
    /// multiple of the spacing inside the tile's square.
    float at(const float* data, std::int64_t x, std::int64_t y) const noexcept {
      const int shift = std::countr_zero(static_cast<std::uint32_t>(spacing));
      return data[offset + static_cast<std::uint64_t>((y - y0) >> shift) * pointsPerRow +
                  static_cast<std::uint64_t>((x - x0) >> shift)];
    }
  };
  /// The tile whose closed square holds the box [x0, x1] × [y0, y1] of `face`, when one does
  /// and no tile the box touches (finestSpacingIn) is finer: then the points forEachInRow visits
  /// in the box are exactly that tile's grid points there.
  std::optional<Window> windowHolding(int face, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                                      std::int32_t y1) const noexcept {
    const std::uint32_t tx = clampTile(x0);
    const std::uint32_t ty = clampTile(y0);
    const std::int64_t cells = tileCells_;
    if (x1 > (tx + 1) * cells || y1 > (ty + 1) * cells) return std::nullopt;
    const std::size_t tile = tileOf(face, tx, ty);
    if (finestSpacingIn(face, x0, y0, x1, y1) != spacing(tile)) return std::nullopt;
    return Window{tx * cells, ty * cells, spacing(tile), offset_[tile], pointsPerRow(tile)};
  }

  /// Calls fn(x, index) for each stored point (x, y) of `face` with lo ≤ x ≤ hi and x a multiple
  /// of `stride` (a power of two), in ascending x, each once.
  template <typename Fn>
  void forEachInRow(int face, std::int32_t y, std::int64_t lo, std::int64_t hi, std::int32_t stride,
                    Fn&& fn) const {
    if (lo > hi) return;
    const std::int64_t cells = tileCells_;
    // The tile rows whose squares hold row y: one, or two on a border between tile rows.
    const std::uint32_t tyHigh = clampTile(y);
    const auto uy = static_cast<std::uint32_t>(y);
    const std::uint32_t tyLow = uy % tileCells_ == 0 && uy > 0 ? uy / tileCells_ - 1 : tyHigh;
    // A point on a vertical border may be stored only by the tile to its left.
    const std::uint32_t txFirst = lo % cells == 0 && lo > 0
                                      ? static_cast<std::uint32_t>(lo / cells) - 1
                                      : clampTile(static_cast<std::int32_t>(lo));
    const std::uint32_t txLast = clampTile(static_cast<std::int32_t>(hi));
    std::int64_t next = lo;  // the first x not yet visited
    for (std::uint32_t tx = txFirst; tx <= txLast; ++tx) {
      // Of the tiles above and below, the finer one that has row y (their grids nest).
      std::size_t tile = kNoTile;
      std::uint32_t tileRow = 0;
      for (std::uint32_t ty = tyLow; ty <= tyHigh; ++ty) {
        const std::size_t k = tileOf(face, tx, ty);
        if (y % spacing(k) != 0) continue;
        if (tile == kNoTile || spacingLog2_[k] < spacingLog2_[tile]) {
          tile = k;
          tileRow = ty;
        }
      }
      if (tile == kNoTile) continue;
      const std::int64_t x0 = static_cast<std::int64_t>(tx) * cells;
      const std::int32_t s = spacing(tile);
      const std::int64_t step = std::max<std::int64_t>(stride, s);
      std::int64_t x = std::max(next, x0);
      x = (x + step - 1) & ~(step - 1);
      const std::int64_t last = std::min(hi, x0 + cells);
      if (x > last) continue;
      const std::int64_t rowInTile = (y - static_cast<std::int64_t>(tileRow) * cells) / s;
      const std::uint64_t indexStep = static_cast<std::uint64_t>(step / s);
      std::uint64_t index = offset_[tile] +
                            static_cast<std::uint64_t>(rowInTile) * pointsPerRow(tile) +
                            static_cast<std::uint64_t>((x - x0) / s);
      for (; x <= last; x += step, index += indexStep) {
        fn(x, index);
        next = x + 1;
      }
    }
  }

 private:
  static constexpr std::size_t kNoTile = std::numeric_limits<std::size_t>::max();
  std::uint32_t clampTile(std::int32_t c) const noexcept {
    return std::min(static_cast<std::uint32_t>(c) / tileCells_, tilesPerSide_ - 1);
  }
  /// The tile column (row) of coordinate c, or the one before it when c lies on a border.
  std::uint32_t below(std::int32_t c) const noexcept {
    const auto u = static_cast<std::uint32_t>(c);
    return u % tileCells_ == 0 && u > 0 ? u / tileCells_ - 1 : clampTile(c);
  }
  std::size_t tileOf(int face, std::uint32_t tx, std::uint32_t ty) const noexcept {
    return (static_cast<std::size_t>(face) * tilesPerSide_ + ty) * tilesPerSide_ + tx;
  }

  std::uint32_t sideCells_ = 0;
  std::uint32_t tileCells_ = 0;
  std::uint32_t tilesPerSide_ = 0;
  bool dense_ = false;
  std::vector<std::uint8_t> spacingLog2_;
  std::vector<std::uint64_t> offset_;    // tileCount + 1
  std::vector<std::uint64_t> rowStart_;  // tileCount + 1
};

/// The heights of one face's lattice points as the patch insertion reads them: dense (no
/// tiles: `data` is the face's (N + 1)² heights, row-major by j) or tiled (`data` is the whole
/// storage of `tiles`, `face` the face).
struct FaceHeights final {
  const float* data = nullptr;
  std::uint32_t sideCells = 0;
  const LatticeTiles* tiles = nullptr;
  int face = 0;
  float at(runtime::LatticeXY p) const noexcept {
    if (tiles != nullptr) return data[tiles->index(face, p)];
    return data[static_cast<std::size_t>(p.y) * (std::size_t{sideCells} + 1) +
                static_cast<std::size_t>(p.x)];
  }
};

}  // namespace pbdam::builder
