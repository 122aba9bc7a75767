// Colour ramps for the default terrain texture: hypsometric tints by height (docs/architecture.md
// "Geometry", "shaded relief with hypsometric tint"; [P-BDAM 2003] §3/§4 texture quadtree
// content). Two ramps: bathymetric blues + green→tan→brown→white land for bodies with oceans
// (Earth), and a blue→green→yellow→red→white ramp spanning the dataset's height range for dry
// bodies (Mars, the Moon). Thread-safety: pure functions.
#pragma once

#include <array>
#include <cstdint>

namespace pbdam::builder {

/// An RGB colour, channels 0..255.
using Rgb8 = std::array<std::uint8_t, 3>;

/// Which ramp to use and the height range it spans.
struct HypsometricRamp final {
  /// True for bodies with oceans: heights < 0 m are water (blues, darker with depth) and heights
  /// >= 0 m land (greens through tan and brown to grey-brown high plateaus, near-white from
  /// 5,800 m), in fixed metre stops so that every Earth dataset looks the same. False: one ramp
  /// stretched over [minMeters, maxMeters] (deep blue at the minimum, white at the maximum).
  bool hasOcean = false;
  double minMeters = -8000.0;  ///< lowest height of the dataset (dry-body ramp only)
  double maxMeters = 21000.0;  ///< highest height; must be > minMeters (dry-body ramp only)
};

/// Returns the tint for `heightMeters` (clamped to the ramp's ends; NaN gives the no-data grey
/// kNoDataTint). Colours are linear interpolations between fixed stops, so the result is
/// continuous in height and deterministic.
Rgb8 hypsometricTint(double heightMeters, const HypsometricRamp& ramp) noexcept;

/// The colour of texels without data (no height and no imagery): a neutral mid grey.
inline constexpr Rgb8 kNoDataTint{128, 128, 128};

}  // namespace pbdam::builder
