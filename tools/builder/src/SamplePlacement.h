// Where the DEM's own samples go on the cube map: their face, bucket and position from the
// bucket's corner, one at a time or a DEM row at a time (private to the builder; SampleGrid.cpp
// buckets them, docs/builder.md "Errors").
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <limits>
#include <optional>
#include <vector>

#include "pbdam/builder/SampleGrid.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/runtime/Direction.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

/// Where a valid DEM sample goes: its face, its bucket (face-major global index) and itself.
struct Placed {
  std::uint32_t bucket = 0;  // UINT32_MAX: not a valid sample
  SourceSample sample;
};

/// The DEM's height at (lat, lon): bicubic, bilinear where bicubic lacks data.
struct DemHeightAt final {
  const formats::HeightGrid& dem;
  std::optional<double> operator()(double lat, double lon) const noexcept {
    auto h = dem.sampleBicubic(lat, lon);
    if (!h) h = dem.sampleBilinear(lat, lon);
    return h;
  }
};

/// Places a sample of height `value` whose unit direction is `d` (see Placed).
Placed placeDirection(const glm::dvec3& d, double n, std::uint32_t bucketCells,
                      std::uint32_t bucketsPerSide, float value);

/// Places a sample of height `value` at (lat, lon) (see Placed).
Placed placeAt(const runtime::Planet& planet, double n, std::uint32_t bucketCells,
               std::uint32_t bucketsPerSide, double lat, double lon, float value);

/// Places a DEM's samples a row at a time (see Placed), as placeAt does each at its row's
/// latitude and column's longitude, bit for bit: the sines and cosines of the columns'
/// longitudes are computed once for all rows, a row's latitude's once for the row.
class DemPlacer final {
 public:
  DemPlacer(const formats::HeightGrid& dem, const runtime::Planet& planet, double n,
            std::uint32_t bucketCells, std::uint32_t bucketsPerSide);
  /// Calls fn(col, placed) for every column of DEM row `row`, in order.
  template <typename Fn>
  void forEachInRow(std::size_t row, const Fn& fn) const {
    const double lat = dem_.latOfRowDegrees(static_cast<std::int64_t>(row));
    Placed none;
    none.bucket = std::numeric_limits<std::uint32_t>::max();
    if (lat < -90.0 || lat > 90.0) {
      for (std::size_t col = 0; col < lon_.size(); ++col) fn(col, none);
      return;
    }
    const runtime::SinCosDegrees sinCosLat = runtime::sinCosDegrees(lat);
    const float* values = dem_.heightsMeters().data() + row * lon_.size();
    for (std::size_t col = 0; col < lon_.size(); ++col) {
      const float value = values[col];
      if (std::isnan(value)) {
        fn(col, none);
      } else {
        fn(col, placeDirection(planet_.geodeticToDirection(sinCosLat, lon_[col]), n_, cells_,
                               perSide_, value));
      }
    }
  }

 private:
  const formats::HeightGrid& dem_;
  const runtime::Planet& planet_;
  double n_;
  std::uint32_t cells_;
  std::uint32_t perSide_;
  std::vector<runtime::SinCosDegrees> lon_;
};

}  // namespace pbdam::builder
