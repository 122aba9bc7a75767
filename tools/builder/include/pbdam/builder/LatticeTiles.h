// Which lattice points a build stores heights for (docs/builder.md "Insets: the sparse
// lattice"). A uniform build stores every point of every face. An adaptive forest goes deep only
// where an inset is, so its lattice is cut into square tiles, each stored at the spacing of the
// finest leaves inside it: a tile of spacing s holds the points of its square (borders included)
// whose coordinates are multiples of s. A point on a border between tiles of different spacings
// is stored by each tile whose grid holds it; its value is the same in each (it is one point of
// one surface). Thread-safety: immutable after construction.
#pragma once

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "pbdam/runtime/Bintree.h"

namespace pbdam::builder {

class LatticeTiles final {
 public:
  /// index() of a point no tile stores.
  static constexpr std::uint64_t kAbsent = std::numeric_limits<std::uint64_t>::max();

  /// One stored tile: the closed square [x0, x0 + cells]² of `face`, its points whose
  /// coordinates are multiples of 2^spacingLog2.
  struct Tile final {
    std::int32_t x0 = 0, y0 = 0;
    std::uint32_t cells = 0;
    std::uint8_t face = 0;
    std::uint8_t spacingLog2 = 0;
    std::int32_t spacing() const noexcept { return std::int32_t{1} << spacingLog2; }
    std::uint32_t pointsPerRow() const noexcept { return (cells >> spacingLog2) + 1; }
  };

  /// A box of one face (half-open: [x0, x1) × [y0, y1) in cells) that wants points every
  /// 2^spacingLog2 cells.
  struct Region final {
    int face = 0;
    std::int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    std::uint8_t spacingLog2 = 0;
  };

  /// Every point of every face of an N-cell lattice: one tile per face at spacing 1, stored as
  /// (N + 1)² heights row-major by j, face after face.
  static LatticeTiles dense(std::uint32_t sideCells);
  /// Squares of `tileCells` cells (a power of two dividing N), tile k at spacing
  /// 2^spacingLog2[k] ≤ tileCells; k = (face · tilesPerSide + ty) · tilesPerSide + tx.
  LatticeTiles(std::uint32_t sideCells, std::uint32_t tileCells,
               std::vector<std::uint8_t> spacingLog2);
  /// An adaptive tiling: squares of `tileCells` cells at spacing 2^baseSpacingLog2, each at the
  /// finest spacing of the regions that share area with it, and a square with more than
  /// `maxPointsPerSide` points a side at that spacing cut into four, recursively (each quarter
  /// at the finest spacing of the regions sharing area with it). Storage: the squares in the
  /// order of the uniform tiling, each one's quarters in the order (0,0), (1,0), (0,1), (1,1).
  static LatticeTiles adaptive(std::uint32_t sideCells, std::uint32_t tileCells,
                               std::uint8_t baseSpacingLog2, std::span<const Region> regions,
                               std::uint32_t maxPointsPerSide);

  std::uint32_t sideCells() const noexcept { return sideCells_; }
  /// The side of the uniform squares the tiling starts from (tiles may be quarters of them).
  std::uint32_t tileCells() const noexcept { return tileCells_; }
  std::size_t tileCount() const noexcept { return tiles_.size(); }
  const Tile& tile(std::size_t k) const noexcept { return tiles_[k]; }
  /// Whether this is the dense layout (every point, one tile per face).
  bool isDense() const noexcept { return dense_; }

  std::int32_t spacing(std::size_t tile) const noexcept { return tiles_[tile].spacing(); }
  /// Points per row (and rows) of a tile: its cells / spacing + 1.
  std::uint32_t pointsPerRow(std::size_t tile) const noexcept {
    return tiles_[tile].pointsPerRow();
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

  /// The spacing of the tile whose square holds point p's cell (clamped at the face's far
  /// edges).
  std::int32_t spacingAt(int face, runtime::LatticeXY p) const noexcept {
    return spacing(tileOfCell(face, clampCell(p.x), clampCell(p.y)));
  }

  /// The finest spacing of the tiles whose closed squares meet the closed box [x0, x1] × [y0,
  /// y1] of `face`: every stored point of the box lies on rows (and columns) that are multiples
  /// of it.
  std::int32_t finestSpacingIn(int face, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                               std::int32_t y1) const noexcept {
    if (dense_) return 1;
    std::uint8_t finest = 255;
    forEachTileMeeting(face, x0, y0, x1, y1, true,
                       [&finest](const Tile& t) { finest = std::min(finest, t.spacingLog2); });
    return std::int32_t{1} << finest;
  }
  /// The coarsest spacing of the tiles whose squares share area with the box [x0, x1) × [y0,
  /// y1) of `face` (x0 < x1, y0 < y1).
  std::int32_t coarsestSpacingIn(int face, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                                 std::int32_t y1) const noexcept {
    if (dense_) return 1;
    std::uint8_t coarsest = 0;
    forEachTileMeeting(face, x0, y0, x1, y1, false, [&coarsest](const Tile& t) {
      coarsest = std::max(coarsest, t.spacingLog2);
    });
    return std::int32_t{1} << coarsest;
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
    const std::size_t k = tileOfCell(face, clampCell(x0), clampCell(y0));
    const Tile& t = tiles_[k];
    const std::int64_t cells = t.cells;
    if (x1 > t.x0 + cells || y1 > t.y0 + cells) return std::nullopt;
    if (finestSpacingIn(face, x0, y0, x1, y1) != t.spacing()) return std::nullopt;
    return Window{t.x0, t.y0, t.spacing(), offset_[k], t.pointsPerRow()};
  }

  /// Calls fn(x, index) for each stored point (x, y) of `face` with lo ≤ x ≤ hi and x a multiple
  /// of `stride` (a power of two), in ascending x, each once.
  template <typename Fn>
  void forEachInRow(int face, std::int32_t y, std::int64_t lo, std::int64_t hi, std::int32_t stride,
                    Fn&& fn) const {
    if (lo > hi) return;
    const std::int64_t n = sideCells_;
    // The tiles whose closed squares hold row y: the one of the cells above it, and on a
    // border the one of the cells below it. Walked in segments where both stay the same, from
    // the cell left of lo (a point on a vertical border may be stored only by the tile to its
    // left).
    const std::int32_t cyAbove = clampCell(y);
    const bool onBorder = y > 0 && y < n;
    std::int64_t next = lo;  // the first x not yet visited
    std::int64_t cx = std::max<std::int64_t>(lo - 1, 0);
    while (cx < n && cx <= hi) {
      const std::size_t above = tileOfCell(face, static_cast<std::int32_t>(cx), cyAbove);
      std::size_t below = kNoTile;
      if (onBorder && tiles_[above].y0 == y) {
        below = tileOfCell(face, static_cast<std::int32_t>(cx), y - 1);
      }
      std::int64_t segmentEnd = tiles_[above].x0 + static_cast<std::int64_t>(tiles_[above].cells);
      if (below != kNoTile) {
        segmentEnd =
            std::min(segmentEnd, tiles_[below].x0 + static_cast<std::int64_t>(tiles_[below].cells));
      }
      // Of the two, the finer one that has row y (their grids nest).
      std::size_t k = kNoTile;
      for (const std::size_t c : {above, below}) {
        if (c == kNoTile || y % tiles_[c].spacing() != 0) continue;
        if (k == kNoTile || tiles_[c].spacingLog2 < tiles_[k].spacingLog2) k = c;
      }
      if (k != kNoTile) {
        const Tile& t = tiles_[k];
        const std::int32_t s = t.spacing();
        const std::int64_t step = std::max<std::int64_t>(stride, s);
        std::int64_t x = std::max(next, cx);
        x = (x + step - 1) & ~(step - 1);
        const std::int64_t last = std::min(hi, segmentEnd);
        const std::int64_t rowInTile = (y - t.y0) / s;
        const std::uint64_t indexStep = static_cast<std::uint64_t>(step / s);
        if (x <= last) {
          std::uint64_t index = offset_[k] +
                                static_cast<std::uint64_t>(rowInTile) * t.pointsPerRow() +
                                static_cast<std::uint64_t>((x - t.x0) / s);
          for (; x <= last; x += step, index += indexStep) {
            fn(x, index);
            next = x + 1;
          }
        }
      }
      cx = segmentEnd;
    }
  }

 private:
  LatticeTiles() = default;
  static constexpr std::size_t kNoTile = std::numeric_limits<std::size_t>::max();
  /// The cell column (row) of a point coordinate: the last cell at the face's far edge.
  std::int32_t clampCell(std::int32_t c) const noexcept {
    return std::min(c, static_cast<std::int32_t>(sideCells_) - 1);
  }
  /// The tile holding cell (cx, cy) of `face` (0 ≤ cx, cy < N).
  std::size_t tileOfCell(int face, std::int32_t cx, std::int32_t cy) const noexcept {
    const auto tx = static_cast<std::uint32_t>(cx) / tileCells_;
    const auto ty = static_cast<std::uint32_t>(cy) / tileCells_;
    std::int64_t node =
        nodes_[(static_cast<std::size_t>(face) * tilesPerSide_ + ty) * tilesPerSide_ + tx];
    std::uint32_t half = tileCells_ / 2;
    std::uint32_t ox = tx * tileCells_;
    std::uint32_t oy = ty * tileCells_;
    while (node >= 0) {
      const std::size_t qx = static_cast<std::uint32_t>(cx) - ox >= half ? 1 : 0;
      const std::size_t qy = static_cast<std::uint32_t>(cy) - oy >= half ? 1 : 0;
      node = nodes_[static_cast<std::size_t>(node) + qx + 2 * qy];
      if (qx != 0) ox += half;
      if (qy != 0) oy += half;
      half /= 2;
    }
    return static_cast<std::size_t>(-node - 1);
  }
  /// Calls fn(tile) for each tile of `face` whose square meets the box [x0, x1] × [y0, y1]:
  /// closed (touching counts) or sharing area ([x0, x1) × [y0, y1)).
  template <typename Fn>
  void forEachTileMeeting(int face, std::int32_t x0, std::int32_t y0, std::int32_t x1,
                          std::int32_t y1, bool closed, Fn&& fn) const {
    const std::int64_t cells = tileCells_;
    const std::int64_t last = static_cast<std::int64_t>(tilesPerSide_) - 1;
    const auto firstOf = [&](std::int64_t c) {
      return std::clamp<std::int64_t>(closed ? (c - 1) / cells : c / cells, 0, last);
    };
    const auto lastOf = [&](std::int64_t c) {
      return std::clamp<std::int64_t>(closed ? c / cells : (c - 1) / cells, 0, last);
    };
    for (std::int64_t ty = firstOf(y0); ty <= lastOf(y1); ++ty) {
      for (std::int64_t tx = firstOf(x0); tx <= lastOf(x1); ++tx) {
        const std::int64_t node =
            nodes_[(static_cast<std::size_t>(face) * tilesPerSide_ + static_cast<std::size_t>(ty)) *
                       tilesPerSide_ +
                   static_cast<std::size_t>(tx)];
        visitNode(node, tx * cells, ty * cells, cells, x0, y0, x1, y1, closed, fn);
      }
    }
  }
  template <typename Fn>
  void visitNode(std::int64_t node, std::int64_t nx, std::int64_t ny, std::int64_t cells,
                 std::int64_t x0, std::int64_t y0, std::int64_t x1, std::int64_t y1, bool closed,
                 Fn& fn) const {
    const bool meets = closed ? nx <= x1 && nx + cells >= x0 && ny <= y1 && ny + cells >= y0
                              : nx < x1 && nx + cells > x0 && ny < y1 && ny + cells > y0;
    if (!meets) return;
    if (node < 0) {
      fn(tiles_[static_cast<std::size_t>(-node - 1)]);
      return;
    }
    const std::int64_t half = cells / 2;
    for (std::int64_t q = 0; q < 4; ++q) {
      visitNode(nodes_[static_cast<std::size_t>(node + q)], nx + (q & 1) * half,
                ny + (q >> 1) * half, half, x0, y0, x1, y1, closed, fn);
    }
  }
  void finishLayout();

  std::uint32_t sideCells_ = 0;
  std::uint32_t tileCells_ = 0;
  std::uint32_t tilesPerSide_ = 0;
  bool dense_ = false;
  std::vector<Tile> tiles_;  // in storage order
  /// The quadtree over the uniform squares: entries [0, 6 · tilesPerSide²) are the squares;
  /// an entry ≥ 0 is the index of its four quarters' entries, one < 0 is tile −entry − 1.
  std::vector<std::int64_t> nodes_;
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
