// Placement of the DEM's own samples on the cube map (SamplePlacement.h).
#include "SamplePlacement.h"

#include <algorithm>

#include "pbdam/runtime/CubeMap.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {

/// Places a sample of height `value` whose unit direction is `d` (see Placed).
Placed placeDirection(const glm::dvec3& d, double n, std::uint32_t bucketCells,
                      std::uint32_t bucketsPerSide, float value) {
  Placed p;
  const FaceUv fuv = CubeMap::directionToFaceUv(d);
  // The bucket of the position, and the position from the bucket's corner in lattice cells
  // (which the inside tests add back to the corner exactly): within [0, bucketCells] as stored.
  const double last = static_cast<double>(bucketsPerSide - 1);
  const double x = fuv.uv.x * n;
  const double y = fuv.uv.y * n;
  const double bx = std::clamp(std::floor(x / bucketCells), 0.0, last);
  const double by = std::clamp(std::floor(y / bucketCells), 0.0, last);
  const auto within = [bucketCells](double cells) {
    return std::clamp(static_cast<float>(cells), 0.0f, static_cast<float>(bucketCells));
  };
  const SourceSample sample{within(x - bx * bucketCells), within(y - by * bucketCells), value};
  const auto face = static_cast<std::uint32_t>(cubeFaceIndex(fuv.face));
  p.bucket = (face * bucketsPerSide + static_cast<std::uint32_t>(by)) * bucketsPerSide +
             static_cast<std::uint32_t>(bx);
  p.sample = sample;
  return p;
}

/// Places a sample of height `value` at (lat, lon) (see Placed).
Placed placeAt(const Planet& planet, double n, std::uint32_t bucketCells,
               std::uint32_t bucketsPerSide, double lat, double lon, float value) {
  if (std::isnan(value) || lat < -90.0 || lat > 90.0) {
    Placed none;
    none.bucket = std::numeric_limits<std::uint32_t>::max();
    return none;
  }
  return placeDirection(planet.geodeticToDirection(lat, lon), n, bucketCells, bucketsPerSide,
                        value);
}

DemPlacer::DemPlacer(const HeightGrid& dem, const Planet& planet, double n,
                     std::uint32_t bucketCells, std::uint32_t bucketsPerSide)
    : dem_(dem), planet_(planet), n_(n), cells_(bucketCells), perSide_(bucketsPerSide) {
  lon_.resize(static_cast<std::size_t>(dem.width()));
  for (std::size_t col = 0; col < lon_.size(); ++col) {
    lon_[col] = sinCosDegrees(dem.lonOfColumnDegrees(static_cast<std::int64_t>(col)));
  }
}

}  // namespace pbdam::builder
