// Greedy insertion into a Delaunay triangulation of a lattice triangle (GreedyInsertion.h).
#include "GreedyInsertion.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>
#include <optional>
#include <queue>

using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

__extension__ using Int128 = __int128;

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
/// A half starts with a coarser candidate stride while it has at least this many candidates
/// at the next coarser stride.
constexpr double kCoarseCandidates = 4096.0;

std::int64_t floorDiv(std::int64_t a, std::int64_t b) noexcept {  // b > 0
  std::int64_t q = a / b;
  if (a % b != 0 && a < 0) --q;
  return q;
}

/// Whether d lies strictly inside the circumcircle of the counter-clockwise triangle (a, b, c).
/// Exact: 128-bit integers hold the determinant for any lattice up to 2^28 cells.
bool inCircle(LatticeXY a, LatticeXY b, LatticeXY c, LatticeXY d) noexcept {
  // Within 2^14 cells of d every product below is under 2^58 and the sum under 2^61: 64 bits
  // hold it exactly, and the answer is the same as in 128.
  constexpr std::int32_t kNear = 1 << 14;
  const auto near = [d](LatticeXY p) {
    return std::abs(p.x - d.x) < kNear && std::abs(p.y - d.y) < kNear;
  };
  if (near(a) && near(b) && near(c)) {
    const std::int64_t adx = a.x - d.x;
    const std::int64_t ady = a.y - d.y;
    const std::int64_t bdx = b.x - d.x;
    const std::int64_t bdy = b.y - d.y;
    const std::int64_t cdx = c.x - d.x;
    const std::int64_t cdy = c.y - d.y;
    return (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
               (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
               (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady) >
           0;
  }
  const Int128 adx = a.x - d.x;
  const Int128 ady = a.y - d.y;
  const Int128 bdx = b.x - d.x;
  const Int128 bdy = b.y - d.y;
  const Int128 cdx = c.x - d.x;
  const Int128 cdy = c.y - d.y;
  const Int128 det = (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) +
                     (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
                     (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
  return det > 0;
}

/// The lattice points of a triangle row by row, every `step`-th row from `firstRow`: inside
/// edge q→r (opposite corner k) means (r − q) × (s − q) ≥ 0, i.e. dy·x ≤ dx·(y − qy) + dy·qx, so
/// each edge bounds x by floor(rhs / |dy|) (dy > 0: from above; dy < 0: from below, negated).
/// The quotients are carried from row to row with their remainders: exact, and one division
/// per edge rather than one per edge and row.
class RowSpans final {
 public:
  RowSpans(const std::array<LatticeXY, 3>& p, const std::array<std::uint32_t, 3>& neighbours,
           int firstRow, int step) noexcept {
    for (std::size_t k = 0; k < 3; ++k) {
      const LatticeXY q = p[(k + 1) % 3];
      const LatticeXY r = p[(k + 2) % 3];
      const std::int64_t dx = r.x - q.x;
      Edge& e = edges_[k];
      e.locked = neighbours[k] == kNone;
      e.dy = r.y - q.y;
      e.rhs = dx * (firstRow - q.y) + e.dy * q.x;
      e.rowStep = dx * step;
      if (e.dy == 0) continue;
      e.divisor = e.dy > 0 ? e.dy : -e.dy;
      e.quotient = floorDiv(e.rhs, e.divisor);
      e.remainder = e.rhs - e.quotient * e.divisor;
      e.stepQuotient = floorDiv(e.rowStep, e.divisor);
      e.stepRemainder = e.rowStep - e.stepQuotient * e.divisor;
    }
  }

  /// Narrows [lo, hi] to this row's span and moves to the next row. True when the row lies on
  /// a locked edge along it (none of its points is a candidate).
  bool next(std::int64_t& lo, std::int64_t& hi) noexcept {
    bool onLockedRow = false;
    for (Edge& e : edges_) {
      if (e.dy > 0) {
        hi = std::min(hi, e.quotient);
      } else if (e.dy < 0) {
        lo = std::max(lo, -e.quotient);  // x ≥ ceil(rhs / dy)
      } else if (e.rhs < 0) {
        hi = lo - 1;
      } else if (e.rhs == 0 && e.locked) {
        onLockedRow = true;
      }
      if (e.dy == 0) {
        e.rhs += e.rowStep;
        continue;
      }
      e.quotient += e.stepQuotient;
      e.remainder += e.stepRemainder;
      if (e.remainder >= e.divisor) {
        e.remainder -= e.divisor;
        ++e.quotient;
      }
    }
    return onLockedRow;
  }

 private:
  struct Edge {
    bool locked = false;
    std::int64_t dy = 0;
    std::int64_t divisor = 1;   // |dy|
    std::int64_t rhs = 0;       // while dy == 0
    std::int64_t quotient = 0;  // floor(rhs / |dy|)
    std::int64_t remainder = 0;
    std::int64_t stepQuotient = 0;  // floor(dx·step / |dy|)
    std::int64_t stepRemainder = 0;
    std::int64_t rowStep = 0;  // dx·step
  };
  std::array<Edge, 3> edges_{};
};

/// A triangle of the triangulation: corners counter-clockwise, n[i] the neighbour across the
/// edge opposite corner i (kNone on the locked boundary).
struct Tri final {
  std::array<std::uint32_t, 3> v{};
  std::array<std::uint32_t, 3> n{};
  double error = -1.0;  // height error + chord bound; < 0: nothing to insert
  LatticeXY candidate{0};
};

struct HeapEntry final {
  double error;
  std::uint32_t tri;
  /// Whether this entry comes out of the queue before `o`: the larger error first, and of
  /// equal errors the lower slot.
  bool before(const HeapEntry& o) const noexcept {
    if (error != o.error) return error > o.error;
    return tri < o.tri;
  }
};

/// The triangles that have a candidate, by error: a binary heap holding one entry per triangle,
/// whose entry moves when the triangle is rescanned (rather than a queue of stale entries,
/// which grows with every scan). The order is total, so the top is the same whichever way the
/// heap got there.
class CandidateQueue final {
 public:
  bool empty() const noexcept { return heap_.empty(); }
  const HeapEntry& top() const noexcept { return heap_.front(); }
  void clear() noexcept {
    for (const HeapEntry& e : heap_) position_[e.tri] = kNone;
    heap_.clear();
  }
  /// Sets triangle t's entry (error ≥ 0) or removes it (error < 0).
  void update(std::uint32_t t, double error) {
    if (t >= position_.size()) position_.resize(std::size_t{t} + 1, kNone);
    const std::uint32_t at = position_[t];
    if (error < 0.0) {
      if (at != kNone) removeAt(at);
      return;
    }
    if (at == kNone) {
      heap_.push_back(HeapEntry{error, t});
      position_[t] = static_cast<std::uint32_t>(heap_.size() - 1);
      up(static_cast<std::uint32_t>(heap_.size() - 1));
      return;
    }
    heap_[at].error = error;
    down(up(at));
  }

 private:
  void place(std::uint32_t at, const HeapEntry& e) noexcept {
    heap_[at] = e;
    position_[e.tri] = at;
  }
  std::uint32_t up(std::uint32_t at) noexcept {
    const HeapEntry e = heap_[at];
    while (at > 0) {
      const std::uint32_t parent = (at - 1) / 2;
      if (!e.before(heap_[parent])) break;
      place(at, heap_[parent]);
      at = parent;
    }
    place(at, e);
    return at;
  }
  void down(std::uint32_t at) noexcept {
    const HeapEntry e = heap_[at];
    const auto size = static_cast<std::uint32_t>(heap_.size());
    for (;;) {
      std::uint32_t child = 2 * at + 1;
      if (child >= size) break;
      if (child + 1 < size && heap_[child + 1].before(heap_[child])) ++child;
      if (!heap_[child].before(e)) break;
      place(at, heap_[child]);
      at = child;
    }
    place(at, e);
  }
  void removeAt(std::uint32_t at) {
    position_[heap_[at].tri] = kNone;
    const HeapEntry last = heap_.back();
    heap_.pop_back();
    if (at == heap_.size()) return;
    place(at, last);
    down(up(at));
  }

  std::vector<HeapEntry> heap_;
  std::vector<std::uint32_t> position_;  // per triangle slot: its index in heap_, or kNone
};

class Triangulation final {
 public:
  Triangulation(const FaceHeights& heights, const ChordModel& chord)
      : heights_(heights),
        sagPerCell2_(chord.radiusMeters > 0.0
                         ? chord.metresPerCell * chord.metresPerCell / (2.0 * chord.radiusMeters)
                         : 0.0) {}

  std::uint32_t addPoint(LatticeXY p) {
    points_.push_back(p);
    z_.push_back(static_cast<double>(heights_.at(p)));
    return static_cast<std::uint32_t>(points_.size() - 1);
  }

  /// The triangle of the three corners (counter-clockwise) and its boundary points, inserted
  /// edge by edge as splits of the boundary edge that holds them.
  void start(const std::array<LatticeXY, 3>& ccw, std::span<const LatticeXY> boundary);

  /// Inserts the candidate of triangle `t` (inside it or on an inner edge).
  void insertCandidate(std::uint32_t t);

  /// Rescans every triangle rewritten since the last call and queues it.
  void rescanDirty();

  /// Candidates are the lattice points whose coordinates are multiples of the stride.
  int stride() const noexcept { return stride_; }
  /// Sets a finer stride and rescans every triangle with it (the queue starts afresh).
  void refineStride(int finer) {
    stride_ = finer;
    queue_.clear();
    dirty_.clear();
    for (std::uint32_t t = 0; t < tris_.size(); ++t) scan(t);
  }
  void setStride(int s) noexcept { stride_ = s; }

  /// The triangle whose candidate comes next, or nothing.
  bool top(HeapEntry& out) const {
    if (queue_.empty()) return false;
    out = queue_.top();
    return true;
  }

  std::size_t vertexCount() const noexcept { return points_.size(); }
  std::size_t triangleCount() const noexcept { return tris_.size(); }
  const std::vector<Tri>& triangles() const noexcept { return tris_; }
  const std::vector<LatticeXY>& points() const noexcept { return points_; }

 private:
  std::uint32_t newTri() {
    tris_.emplace_back();
    return static_cast<std::uint32_t>(tris_.size() - 1);
  }
  void set(std::uint32_t t, std::array<std::uint32_t, 3> v, std::array<std::uint32_t, 3> n) {
    Tri& tri = tris_[t];
    tri.v = v;
    tri.n = n;
    dirty_.push_back(t);
  }
  /// Points neighbour `of` (if any) at `to` where it pointed at `from`.
  void repoint(std::uint32_t of, std::uint32_t from, std::uint32_t to) {
    if (of == kNone) return;
    for (std::uint32_t& k : tris_[of].n) {
      if (k == from) k = to;
    }
  }
  static int slot(const Tri& t, std::uint32_t vertex) noexcept {
    return t.v[0] == vertex ? 0 : (t.v[1] == vertex ? 1 : 2);
  }
  void splitBoundaryEdge(std::uint32_t t, int opposite, std::uint32_t p);
  void splitInside(std::uint32_t t, std::uint32_t p);
  void splitInnerEdge(std::uint32_t t, int opposite, std::uint32_t p);
  /// Lawson flips from the edges opposite corner 0 of the queued triangles.
  void legalize();
  void scan(std::uint32_t t);

  const FaceHeights& heights_;
  double sagPerCell2_;
  std::vector<LatticeXY> points_;
  std::vector<double> z_;
  std::vector<Tri> tris_;
  std::vector<std::uint32_t> dirty_;
  std::vector<std::uint32_t> pending_;  // triangles whose edge opposite corner 0 is to check
  CandidateQueue queue_;
  int stride_ = 1;
};

void Triangulation::start(const std::array<LatticeXY, 3>& ccw,
                          std::span<const LatticeXY> boundary) {
  const std::array<std::uint32_t, 3> c = {addPoint(ccw[0]), addPoint(ccw[1]), addPoint(ccw[2])};
  const std::uint32_t first = newTri();
  set(first, {c[0], c[1], c[2]}, {kNone, kNone, kNone});
  for (int e = 0; e < 3; ++e) {
    // Edge from corner e+1 to corner e+2 (opposite corner e): its boundary points by distance.
    const LatticeXY from = ccw[static_cast<std::size_t>((e + 1) % 3)];
    const LatticeXY to = ccw[static_cast<std::size_t>((e + 2) % 3)];
    const LatticeXY dir = to - from;
    const std::int64_t len2 = std::int64_t{dir.x} * dir.x + std::int64_t{dir.y} * dir.y;
    std::vector<std::pair<std::int64_t, LatticeXY>> onEdge;
    for (const LatticeXY p : boundary) {
      if (doubleArea(from, to, p) != 0) continue;
      const LatticeXY d = p - from;
      const std::int64_t s = std::int64_t{d.x} * dir.x + std::int64_t{d.y} * dir.y;
      if (s > 0 && s < len2) onEdge.emplace_back(s, p);
    }
    std::sort(onEdge.begin(), onEdge.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    onEdge.erase(std::unique(onEdge.begin(), onEdge.end(),
                             [](const auto& a, const auto& b) { return a.first == b.first; }),
                 onEdge.end());
    if (onEdge.empty()) continue;
    // The triangle that holds this boundary edge: the split keeps each remaining part of it in
    // the same slot (flips around the new point never touch the boundary edge's triangle slot).
    const std::uint32_t toIndex = c[static_cast<std::size_t>((e + 2) % 3)];
    std::uint32_t holder = kNone;
    const std::uint32_t fromIndex = c[static_cast<std::size_t>((e + 1) % 3)];
    for (std::uint32_t t = 0; t < tris_.size() && holder == kNone; ++t) {
      const Tri& tri = tris_[t];
      for (int k = 0; k < 3; ++k) {
        if (tri.n[static_cast<std::size_t>(k)] == kNone &&
            tri.v[static_cast<std::size_t>((k + 1) % 3)] == fromIndex &&
            tri.v[static_cast<std::size_t>((k + 2) % 3)] == toIndex) {
          holder = t;
        }
      }
    }
    assert(holder != kNone);
    for (const auto& [s, p] : onEdge) {
      const std::uint32_t index = addPoint(p);
      const Tri& tri = tris_[holder];
      const int far = slot(tri, toIndex);
      splitBoundaryEdge(holder, (far + 1) % 3, index);
      legalize();
    }
  }
}

void Triangulation::splitBoundaryEdge(std::uint32_t t, int opposite, std::uint32_t p) {
  // t = (a, b, c) with the boundary edge b–c opposite a; p on it. A1 = (p, a, b) in a new slot,
  // A2 = (p, c, a) in t's slot, which keeps the boundary edge p–c.
  const Tri old = tris_[t];
  const auto k = static_cast<std::size_t>(opposite);
  const std::uint32_t a = old.v[k];
  const std::uint32_t b = old.v[(k + 1) % 3];
  const std::uint32_t c = old.v[(k + 2) % 3];
  const std::uint32_t acrossAB = old.n[(k + 2) % 3];
  const std::uint32_t acrossCA = old.n[(k + 1) % 3];
  const std::uint32_t a1 = newTri();
  set(a1, {p, a, b}, {acrossAB, kNone, t});
  set(t, {p, c, a}, {acrossCA, a1, kNone});
  repoint(acrossAB, t, a1);
  pending_.push_back(a1);
  pending_.push_back(t);
}

void Triangulation::splitInside(std::uint32_t t, std::uint32_t p) {
  const Tri old = tris_[t];
  const std::uint32_t a = old.v[0];
  const std::uint32_t b = old.v[1];
  const std::uint32_t c = old.v[2];
  const std::uint32_t t1 = newTri();
  const std::uint32_t t2 = newTri();
  set(t, {p, b, c}, {old.n[0], t1, t2});
  set(t1, {p, c, a}, {old.n[1], t2, t});
  set(t2, {p, a, b}, {old.n[2], t, t1});
  repoint(old.n[1], t, t1);
  repoint(old.n[2], t, t2);
  pending_.insert(pending_.end(), {t, t1, t2});
}

void Triangulation::splitInnerEdge(std::uint32_t t, int opposite, std::uint32_t p) {
  // t = (a, b, c), p on b–c, u = (d, c, b) across it. A1 = (p, a, b) in t, A2 = (p, c, a),
  // B1 = (p, d, c) in u, B2 = (p, b, d).
  const Tri ot = tris_[t];
  const auto k = static_cast<std::size_t>(opposite);
  const std::uint32_t a = ot.v[k];
  const std::uint32_t b = ot.v[(k + 1) % 3];
  const std::uint32_t c = ot.v[(k + 2) % 3];
  const std::uint32_t u = ot.n[k];
  const Tri ou = tris_[u];
  std::size_t j = 0;
  while (ou.n[j] != t) ++j;
  const std::uint32_t d = ou.v[j];
  const std::uint32_t tAB = ot.n[(k + 2) % 3];
  const std::uint32_t tCA = ot.n[(k + 1) % 3];
  // In u = (d, c, b): the edge d–c is opposite b, b–d opposite c.
  const std::uint32_t uDC = ou.n[(j + 2) % 3];
  const std::uint32_t uBD = ou.n[(j + 1) % 3];
  const std::uint32_t a2 = newTri();
  const std::uint32_t b2 = newTri();
  set(t, {p, a, b}, {tAB, b2, a2});
  set(a2, {p, c, a}, {tCA, t, u});
  set(u, {p, d, c}, {uDC, a2, b2});
  set(b2, {p, b, d}, {uBD, u, t});
  repoint(tCA, t, a2);
  repoint(uBD, u, b2);
  pending_.insert(pending_.end(), {t, a2, u, b2});
}

void Triangulation::legalize() {
  while (!pending_.empty()) {
    const std::uint32_t t = pending_.back();
    pending_.pop_back();
    const Tri tri = tris_[t];
    const std::uint32_t u = tri.n[0];
    if (u == kNone) continue;
    const Tri other = tris_[u];
    std::size_t j = 0;
    while (other.n[j] != t) ++j;
    const std::uint32_t a = tri.v[0];
    const std::uint32_t b = tri.v[1];
    const std::uint32_t c = tri.v[2];
    const std::uint32_t d = other.v[j];
    if (!inCircle(points_[a], points_[b], points_[c], points_[d])) continue;
    // Flip b–c to a–d: t = (a, b, d), u = (a, d, c).
    const std::uint32_t uBD = other.n[(j + 1) % 3];
    const std::uint32_t uDC = other.n[(j + 2) % 3];
    set(t, {a, b, d}, {uBD, u, tri.n[2]});
    set(u, {a, d, c}, {uDC, tri.n[1], t});
    repoint(uBD, u, t);
    repoint(tri.n[1], t, u);
    pending_.push_back(t);
    pending_.push_back(u);
  }
}

void Triangulation::insertCandidate(std::uint32_t t) {
  const Tri tri = tris_[t];
  const std::uint32_t p = addPoint(tri.candidate);
  for (int k = 0; k < 3; ++k) {
    const LatticeXY b = points_[tri.v[static_cast<std::size_t>((k + 1) % 3)]];
    const LatticeXY c = points_[tri.v[static_cast<std::size_t>((k + 2) % 3)]];
    if (doubleArea(b, c, tri.candidate) == 0) {
      assert(tri.n[static_cast<std::size_t>(k)] != kNone);
      splitInnerEdge(t, k, p);
      legalize();
      return;
    }
  }
  splitInside(t, p);
  legalize();
}

void Triangulation::rescanDirty() {
  std::sort(dirty_.begin(), dirty_.end());
  dirty_.erase(std::unique(dirty_.begin(), dirty_.end()), dirty_.end());
  for (const std::uint32_t t : dirty_) scan(t);
  dirty_.clear();
}

/// A triangle's plane through its corners' heights and its circumcircle (the chord's sag), and
/// the worst lattice point found so far: the per-point work of a scan.
class PlaneScan final {
 public:
  PlaneScan(const std::array<LatticeXY, 3>& p, const std::array<double, 3>& z,
            double sagPerCell2) noexcept
      : p_(p), z_(z), p0_(p[0]), z0_(z[0]), sagPerCell2_(sagPerCell2) {}

  /// Sets up the plane and the circumcircle (before the first row).
  void prepare() noexcept {
    const std::array<LatticeXY, 3>& p = p_;
    const std::array<double, 3>& z = z_;
    // The plane through the corners' heights, z = z0 + gx (x − x0) + gy (y − y0).
    const auto det = static_cast<double>(doubleArea(p[0], p[1], p[2]));
    const double e1x = p[1].x - p[0].x;
    const double e1y = p[1].y - p[0].y;
    const double e2x = p[2].x - p[0].x;
    const double e2y = p[2].y - p[0].y;
    gx_ = ((z[1] - z[0]) * e2y - (z[2] - z[0]) * e1y) / det;
    gy_ = (e1x * (z[2] - z[0]) - e2x * (z[1] - z[0])) / det;
    // Circumcentre (relative to p0) and squared circumradius, in cells.
    const double l1 = e1x * e1x + e1y * e1y;
    const double l2 = e2x * e2x + e2y * e2y;
    ccx_ = (e2y * l1 - e1y * l2) / (2.0 * det);
    ccy_ = (e1x * l2 - e2x * l1) / (2.0 * det);
    rc2_ = ccx_ * ccx_ + ccy_ * ccy_;
    // The largest sag inside the triangle.
    const double e0x = p[2].x - p[1].x;
    const double e0y = p[2].y - p[1].y;
    const double l0 = e0x * e0x + e0y * e0y;
    const double longest = std::max({l0, l1, l2});
    const bool acute = 2.0 * longest < l0 + l1 + l2;
    chordBound_ = sagPerCell2_ * (acute ? rc2_ : 0.25 * longest);
  }

  /// Starts row y.
  void row(int y) noexcept {
    y_ = y;
    const double ry = static_cast<double>(y - p0_.y);
    gyry_ = gy_ * ry;
    const double dcy = ry - ccy_;
    dcy2_ = dcy * dcy;
  }
  /// Lattice point (x, current row) of this height.
  void visit(std::int64_t x, float height) noexcept {
    const double rx = static_cast<double>(x - p0_.x);
    const double dev = std::abs(static_cast<double>(height) - (z0_ + gx_ * rx + gyry_));
    const double dcx = rx - ccx_;
    const double sag = sagPerCell2_ * std::max(0.0, rc2_ - (dcx * dcx + dcy2_));
    worstHeight_ = std::max(worstHeight_, dev);
    if (dev + sag > worstScore_) {
      worstScore_ = dev + sag;
      worst_ = LatticeXY{static_cast<std::int32_t>(x), y_};
    }
  }

  /// The triangle's error (height error plus chord bound; < 0 when no point was visited) and
  /// its candidate.
  double error() const noexcept { return worstScore_ < 0.0 ? -1.0 : worstHeight_ + chordBound_; }
  LatticeXY candidate() const noexcept { return worst_; }

 private:
  std::array<LatticeXY, 3> p_;
  std::array<double, 3> z_;
  LatticeXY p0_;
  double z0_;
  double sagPerCell2_;
  double gx_ = 0.0;
  double gy_ = 0.0;
  double ccx_ = 0.0;
  double ccy_ = 0.0;
  double rc2_ = 0.0;
  double chordBound_ = 0.0;
  int y_ = 0;
  double gyry_ = 0.0;
  double dcy2_ = 0.0;
  double worstHeight_ = -1.0;
  double worstScore_ = -1.0;
  LatticeXY worst_{0};
};

/// A triangle scans its box point by point (three edge functions stepped by additions) rather
/// than row spans (six 64-bit divisions to set up) while its box holds at most this many
/// candidates: most triangles of a half near its end cover a handful of points. Both visit the
/// same points in the same order.
constexpr std::int64_t kBoxScanPoints = 48;

/// Visits the points of the dense-lattice triangle p (counter-clockwise) on every `step`-th row
/// and column of its box, in row order, that are candidates: inside or on it, neither a corner
/// nor on a locked edge (locked[k]: the edge opposite corner k).
void scanBox(const std::array<LatticeXY, 3>& p, const std::array<bool, 3>& locked, int step,
             int firstRow, int yMax, int firstColumn, int xMax, const float* heights,
             std::size_t rowLength, PlaneScan& plane) {
  std::array<std::int64_t, 3> rowEdge{};
  std::array<std::int64_t, 3> stepX{};
  std::array<std::int64_t, 3> stepY{};
  for (std::size_t k = 0; k < 3; ++k) {
    const LatticeXY q = p[(k + 1) % 3];
    const LatticeXY r = p[(k + 2) % 3];
    // (r − q) × (s − q): ≥ 0 inside, linear in s.
    rowEdge[k] =
        std::int64_t{r.x - q.x} * (firstRow - q.y) - std::int64_t{r.y - q.y} * (firstColumn - q.x);
    stepX[k] = -std::int64_t{r.y - q.y} * step;
    stepY[k] = std::int64_t{r.x - q.x} * step;
  }
  // The candidates first: a triangle without any (most of the smallest) skips the plane's set-up.
  std::array<LatticeXY, kBoxScanPoints> found;
  std::size_t count = 0;
  for (int y = firstRow; y <= yMax; y += step) {
    std::array<std::int64_t, 3> e = rowEdge;
    for (int x = firstColumn; x <= xMax; x += step) {
      if (e[0] >= 0 && e[1] >= 0 && e[2] >= 0) {
        const bool z0 = e[0] == 0;
        const bool z1 = e[1] == 0;
        const bool z2 = e[2] == 0;
        // Two edges through it: a corner.
        const bool excluded =
            (z0 && locked[0]) || (z1 && locked[1]) || (z2 && locked[2]) ||
            static_cast<int>(z0) + static_cast<int>(z1) + static_cast<int>(z2) >= 2;
        if (!excluded) found[count++] = LatticeXY{x, y};
      }
      e[0] += stepX[0];
      e[1] += stepX[1];
      e[2] += stepX[2];
    }
    rowEdge[0] += stepY[0];
    rowEdge[1] += stepY[1];
    rowEdge[2] += stepY[2];
  }
  if (count == 0) return;
  plane.prepare();
  int rowY = -1;
  for (std::size_t k = 0; k < count; ++k) {
    if (found[k].y != rowY) {
      rowY = found[k].y;
      plane.row(rowY);
    }
    plane.visit(found[k].x, heights[static_cast<std::size_t>(found[k].y) * rowLength +
                                    static_cast<std::size_t>(found[k].x)]);
  }
}

void Triangulation::scan(std::uint32_t t) {
  Tri& tri = tris_[t];
  const std::array<LatticeXY, 3> p = {points_[tri.v[0]], points_[tri.v[1]], points_[tri.v[2]]};
  PlaneScan plane(p, {z_[tri.v[0]], z_[tri.v[1]], z_[tri.v[2]]}, sagPerCell2_);
  const int yMin = std::min({p[0].y, p[1].y, p[2].y});
  const int yMax = std::max({p[0].y, p[1].y, p[2].y});
  const int xMinBox = std::min({p[0].x, p[1].x, p[2].x});
  const int xMaxBox = std::max({p[0].x, p[1].x, p[2].x});
  // A power of two. On a sparse lattice, at least the finest spacing stored under the
  // triangle: no row or column between its multiples holds a stored point.
  const int step = heights_.tiles == nullptr
                       ? stride_
                       : std::max(stride_, heights_.tiles->finestSpacingIn(heights_.face, xMinBox,
                                                                           yMin, xMaxBox, yMax));
  // Lattice coordinates are never negative.
  const auto roundUp = [step](std::int64_t v) { return (v + step - 1) & ~std::int64_t{step - 1}; };
  const auto roundDown = [step](std::int64_t v) { return v & ~std::int64_t{step - 1}; };
  const int firstRow = static_cast<int>(roundUp(yMin));
  const float* heights = heights_.data;
  const std::size_t rowLength = std::size_t{heights_.sideCells} + 1;
  const auto firstColumn = static_cast<int>(roundUp(xMinBox));
  const std::int64_t boxPoints =
      std::int64_t{(yMax - firstRow) / step + 1} * ((xMaxBox - firstColumn) / step + 1);
  if (heights_.tiles == nullptr && boxPoints <= kBoxScanPoints) {
    scanBox(p, {tri.n[0] == kNone, tri.n[1] == kNone, tri.n[2] == kNone}, step, firstRow, yMax,
            firstColumn, xMaxBox, heights, rowLength, plane);
    tri.error = plane.error();
    tri.candidate = plane.candidate();
    queue_.update(t, tri.error);
    return;
  }
  // Not candidates: the corners and the points on a locked edge. Along a row they can only be
  // the ends of the span (or the whole row, on a locked edge along the row).
  const auto excluded = [&](LatticeXY s) {
    if (s == p[0] || s == p[1] || s == p[2]) return true;
    for (std::size_t k = 0; k < 3; ++k) {
      if (tri.n[k] == kNone && doubleArea(p[(k + 1) % 3], p[(k + 2) % 3], s) == 0) return true;
    }
    return false;
  };
  plane.prepare();
  RowSpans spans(p, tri.n, firstRow, step);
  // On a sparse lattice, a triangle inside one tile (no finer tile touching it) reads that
  // tile's grid directly, as a dense lattice's rows: the same points, without the row walk.
  std::optional<LatticeTiles::Window> window;
  if (heights_.tiles != nullptr) {
    window = heights_.tiles->windowHolding(heights_.face, xMinBox, yMin, xMaxBox, yMax);
  }
  for (int y = firstRow; y <= yMax; y += step) {
    std::int64_t lo = xMinBox;
    std::int64_t hi = xMaxBox;
    const bool onLockedRow = spans.next(lo, hi);
    if (onLockedRow) continue;
    std::int64_t first = roundUp(lo);
    std::int64_t last = roundDown(hi);
    if (first > last) continue;
    if (excluded(LatticeXY{static_cast<std::int32_t>(first), y})) first += step;
    if (first <= last && excluded(LatticeXY{static_cast<std::int32_t>(last), y})) last -= step;
    plane.row(y);
    if (window) {
      for (std::int64_t x = first; x <= last; x += step) plane.visit(x, window->at(heights, x, y));
      continue;
    }
    if (heights_.tiles != nullptr) {
      // A sparse lattice: the points stored, each tile at its own spacing.
      heights_.tiles->forEachInRow(
          heights_.face, y, first, last, step,
          [&](std::int64_t x, std::uint64_t at) { plane.visit(x, heights[at]); });
      continue;
    }
    const float* row = heights + static_cast<std::size_t>(y) * rowLength;
    for (std::int64_t x = first; x <= last; x += step) plane.visit(x, row[x]);
  }
  tri.error = plane.error();
  tri.candidate = plane.candidate();
  queue_.update(t, tri.error);
}

}  // namespace

InsertionResult insertGreedily(const FaceHeights& heights, const std::array<LatticeXY, 3>& corners,
                               std::span<const LatticeXY> boundary, const InsertionLimits& limits,
                               const ChordModel& chord) {
  std::array<LatticeXY, 3> ccw = corners;
  if (doubleArea(ccw[0], ccw[1], ccw[2]) < 0) std::swap(ccw[1], ccw[2]);
  Triangulation tin(heights, chord);
  // Coarse to fine: while a half has many lattice points per candidate it needs, its first
  // insertions choose among every 2nd, 4th, … point (each triangle scans a stride² of what it
  // covers), then the stride halves and every triangle is scanned again, down to every point.
  // The big early triangles are thus never scanned in full, and the final pass at stride 1
  // decides the stop exactly as a single pass would.
  const double points = 0.5 * static_cast<double>(std::abs(doubleArea(ccw[0], ccw[1], ccw[2])));
  int stride = std::max(1, limits.spacing);
  while (points / (4.0 * stride * stride) >= kCoarseCandidates) stride *= 2;
  tin.setStride(stride);
  tin.start(ccw, boundary);
  tin.rescanDirty();
  InsertionResult result;
  HeapEntry best{};
  for (;;) {
    while (tin.top(best) && tin.vertexCount() < limits.maxVertices) {
      const bool enough = tin.triangleCount() >= limits.minTriangles;
      if (best.error <= 0.0 || (enough && best.error <= limits.targetMeters)) break;
      tin.insertCandidate(best.tri);
      tin.rescanDirty();
      ++result.insertedPoints;
    }
    const int last = std::max(1, limits.spacing);
    if (tin.stride() <= last) break;
    // At the vertex cap only the exact error is left to know.
    tin.refineStride(tin.vertexCount() >= limits.maxVertices ? last : tin.stride() / 2);
  }
  result.maxErrorMeters = tin.top(best) ? std::max(0.0, best.error) : 0.0;
  result.patch.points = tin.points();
  result.patch.indices.reserve(3 * tin.triangleCount());
  for (const Tri& t : tin.triangles()) {
    result.patch.indices.insert(result.patch.indices.end(), t.v.begin(), t.v.end());
  }
  return result;
}

std::vector<std::size_t> insertAlongSegment(std::span<const double> heights, double stepCells,
                                            double targetMeters, const ChordModel& chord) {
  assert(heights.size() >= 2);
  const std::size_t n = heights.size() - 1;
  const double sagPerStep2 = chord.radiusMeters > 0.0 ? (stepCells * chord.metresPerCell) *
                                                            (stepCells * chord.metresPerCell) /
                                                            (2.0 * chord.radiusMeters)
                                                      : 0.0;
  std::vector<bool> kept(n + 1, false);
  kept[0] = kept[n] = true;
  struct Span {
    double error;
    std::size_t from, to, worst;
    bool operator<(const Span& o) const noexcept {
      return error != o.error ? error < o.error : from > o.from;
    }
  };
  std::priority_queue<Span> spans;
  const auto push = [&](std::size_t from, std::size_t to) {
    if (to - from < 2) return;
    Span s{-1.0, from, to, from};
    const double h0 = heights[from];
    const double slope = (heights[to] - h0) / static_cast<double>(to - from);
    for (std::size_t k = from + 1; k < to; ++k) {
      const auto a = static_cast<double>(k - from);
      const auto b = static_cast<double>(to - k);
      // A chord of the segment sags a·b·step²/(2R) below the surface at k.
      const double e = std::abs(heights[k] - (h0 + slope * a)) + sagPerStep2 * a * b;
      if (e > s.error) {
        s.error = e;
        s.worst = k;
      }
    }
    spans.push(s);
  };
  push(0, n);
  while (!spans.empty() && spans.top().error > targetMeters) {
    const Span s = spans.top();
    spans.pop();
    kept[s.worst] = true;
    push(s.from, s.worst);
    push(s.worst, s.to);
  }
  std::vector<std::size_t> out;
  for (std::size_t k = 0; k <= n; ++k) {
    if (kept[k]) out.push_back(k);
  }
  return out;
}

}  // namespace pbdam::builder
