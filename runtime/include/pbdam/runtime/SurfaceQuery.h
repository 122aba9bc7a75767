// Height of the rendered terrain surface at a latitude/longitude (`pbdam height`, camera
// placement): the leaf patches around the point are decoded and the geodetic normal line through
// (lat, lon) is intersected with their triangles, each vertex placed in double exactly where the
// renderer draws it (runtime/PatchDraw.h). Leaves are what a renderer draws up close, so this is
// the height a camera would see at full detail; it differs from the source DEM by at most the
// leaf's stored error. Thread-safety: pure; decodes into its own buffers (a SurfaceLeafCache,
// when passed, is the caller's and is not shared between threads).
#pragma once

#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <unordered_map>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::runtime {

/// The rendered surface's height at a point, and the leaf patch it was read from.
struct SurfaceHeight final {
  double heightMeters = 0.0;             ///< above the reference surface, along the geodetic normal
  NodeKey leaf;                          ///< the leaf patch whose triangle was hit
  double leafErrorMeters = 0.0;          ///< its saturated stored error
  double leafMeasuredErrorMeters = 0.0;  ///< its own measured error (against its sources)
  /// The leaf's sources (formats::NodeRecord::sources): 0 when the dataset has no insets.
  std::uint32_t leafSources = 0;
};

class SurfaceLeafCache;

/// The rendered surface height at geodetic (lat, lon) in degrees. InvalidArgument for
/// out-of-range coordinates, CorruptData if a patch fails to decode.
formats::Result<SurfaceHeight> surfaceHeightAt(const DatasetView& dataset, double latDegrees,
                                               double lonDegrees);
/// The same, with the leaves it needs taken from `cache` or decoded into it.
formats::Result<SurfaceHeight> surfaceHeightAt(const DatasetView& dataset, double latDegrees,
                                               double lonDegrees, SurfaceLeafCache& cache);

/// Leaves surfaceHeightAt has decoded and placed, kept for later calls by a caller that asks for
/// many nearby points (a ray march along a segment): each leaf is decoded once instead of at
/// every point. Without one, surfaceHeightAt uses a cache of its own for the one call, so the
/// answers are the same either way. It holds at most `maxLeaves` leaves (when full it starts
/// over) of one dataset view (another view empties it): one cache per view, used while the view
/// lives. Not thread-safe.
class SurfaceLeafCache final {
 public:
  /// An empty cache of at most `maxLeaves` leaves.
  explicit SurfaceLeafCache(std::size_t maxLeaves = 256) : maxLeaves_(maxLeaves) {}
  /// Leaves decoded through this cache so far (each decode, not each use).
  std::size_t decodedLeaves() const noexcept { return decodedLeaves_; }

  /// One leaf's triangles where they are drawn, and a sphere around them (surfaceHeightAt's).
  struct Leaf final {
    std::vector<glm::dvec3> positions;   ///< planetocentric metres, as drawn
    std::vector<std::uint16_t> indices;  ///< three a triangle
    glm::dvec3 centre{0.0};              ///< of a sphere holding every position
    double radius = 0.0;                 ///< of that sphere, metres
  };

 private:
  friend formats::Result<SurfaceHeight> surfaceHeightAt(const DatasetView&, double, double,
                                                        SurfaceLeafCache&);
  const DatasetView* view_ = nullptr;
  std::unordered_map<std::uint64_t, Leaf> leaves_;  ///< by packKey()
  std::size_t maxLeaves_;
  std::size_t decodedLeaves_ = 0;
};

}  // namespace pbdam::runtime
