// Pieces the leaf patches and the block simplification share (PatchBuilder.h): a patch under
// construction with a point lookup, and its compaction. Private to the builder.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "pbdam/builder/Lattice.h"
#include "pbdam/builder/PatchBuilder.h"

namespace pbdam::builder {

inline std::uint64_t packXY(runtime::LatticeXY p) noexcept {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(p.x)) << 32) |
         static_cast<std::uint32_t>(p.y);
}

/// A patch under construction with a point → index lookup (open addressing with linear
/// probing; points are numbered in first-use order, so the result does not depend on the table).
struct IndexedPatch final {
  std::vector<runtime::LatticeXY> points;
  std::vector<std::uint32_t> indices;

  explicit IndexedPatch(std::size_t expectedPoints = 64) {
    std::size_t capacity = 64;
    while (capacity < 2 * expectedPoints) capacity *= 2;
    slots_.assign(capacity, kEmpty);
  }

  std::uint32_t add(runtime::LatticeXY p) {
    const std::uint64_t key = packXY(p);
    const std::size_t mask = slots_.size() - 1;
    // A multiplicative hash of the packed point (Fibonacci hashing); the top bits pick the slot.
    std::size_t slot = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ULL) >> 32) & mask;
    while (slots_[slot] != kEmpty) {
      if (packXY(points[slots_[slot]]) == key) return slots_[slot];
      slot = (slot + 1) & mask;
    }
    const auto index = static_cast<std::uint32_t>(points.size());
    points.push_back(p);
    slots_[slot] = index;
    if (2 * points.size() > slots_.size()) grow();
    return index;
  }
  /// Adds a triangle, wound counter-clockwise in (u,v).
  void addTriangle(runtime::LatticeXY a, runtime::LatticeXY b, runtime::LatticeXY c) {
    if (doubleArea(a, b, c) < 0) std::swap(b, c);
    indices.push_back(add(a));
    indices.push_back(add(b));
    indices.push_back(add(c));
  }

 private:
  static constexpr std::uint32_t kEmpty = std::numeric_limits<std::uint32_t>::max();
  void grow() {
    slots_.assign(slots_.size() * 2, kEmpty);
    const std::size_t mask = slots_.size() - 1;
    for (std::uint32_t i = 0; i < points.size(); ++i) {
      std::size_t slot =
          static_cast<std::size_t>((packXY(points[i]) * 0x9E3779B97F4A7C15ULL) >> 32) & mask;
      while (slots_[slot] != kEmpty) slot = (slot + 1) & mask;
      slots_[slot] = i;
    }
  }
  std::vector<std::uint32_t> slots_;
};

/// Drops unreferenced points and renumbers (first-use order keeps it deterministic).
WorkPatch compact(const std::vector<runtime::LatticeXY>& points,
                  const std::vector<std::uint32_t>& indices);

}  // namespace pbdam::builder
