// A small synthetic global DEM for builder tests: 120 × 60 samples at 3°, heights that change
// sharply from sample to sample (3000·sin(0.37k) + 1700·cos(1.91k) m over the sample index k),
// so that every patch has source samples to be measured against.
#pragma once

#include <cmath>
#include <cstddef>
#include <vector>

#include "pbdam/formats/HeightGrid.h"

namespace pbdam::test {

inline formats::HeightGrid roughDem() {
  formats::GridGeometry g;
  g.width = 120;
  g.height = 60;
  g.firstLatDegrees = 88.5;
  g.firstLonDegrees = 1.5;
  g.latSpacingDegrees = 3.0;
  g.lonSpacingDegrees = 3.0;
  g.pixelIsArea = true;
  std::vector<float> heights(static_cast<std::size_t>(g.width * g.height));
  for (std::size_t k = 0; k < heights.size(); ++k) {
    const double x = static_cast<double>(k);
    heights[k] = static_cast<float>(3000.0 * std::sin(0.37 * x) + 1700.0 * std::cos(1.91 * x));
  }
  return formats::HeightGrid(g, std::move(heights), formats::GridSource{});
}

}  // namespace pbdam::test
