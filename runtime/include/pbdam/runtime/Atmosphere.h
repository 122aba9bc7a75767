// Physically based atmospheric scattering with precomputed tables (docs/architecture.md "Light"):
// Bruneton and Neyret's model (Precomputed Atmospheric Scattering, EGSR 2008) in the
// parametrisation of Bruneton's 2017 reference implementation — Rayleigh and Mie scattering and an
// absorbing layer, each with an altitude profile, multiple scattering to a chosen order, light
// reflected by the ground — written here for the host. The tables are what the shaders sample
// (transmittance, scattering, single Mie scattering, ground irradiance); the functions below
// evaluate the same lookups on the host, for tests and for the renderer's checks.
//
// Units: lengths in metres, radiance in W·m⁻²·sr⁻¹·nm⁻¹ at three wavelengths (680, 550 and 440 nm,
// as R, G, B), irradiance in W·m⁻²·nm⁻¹. Positions are relative to the planet's centre.
// Thread-safety: tables are immutable once made; all functions are const.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <glm/vec3.hpp>
#include <optional>
#include <vector>

#include "pbdam/runtime/Planet.h"

namespace pbdam::runtime {

/// One layer of an altitude profile: exp_term·exp(exp_scale·h) + linear_term·h + constant_term,
/// clamped to [0, 1] (h: altitude in metres).
struct DensityLayer final {
  double widthMeters = 0.0;   ///< where the next layer starts (the last layer's is ignored)
  double expTerm = 0.0;       ///< factor of the exponential
  double expScale = 0.0;      ///< per metre (−1 / scale height)
  double linearTerm = 0.0;    ///< per metre
  double constantTerm = 0.0;  ///< constant
};

/// An altitude profile of two layers (the lower one up to its width).
struct DensityProfile final {
  std::array<DensityLayer, 2> layers{};  ///< the lower layer, then the one above it
  /// The density at `altitudeMeters` above the bottom of the atmosphere.
  double at(double altitudeMeters) const noexcept;
  /// An exponential profile of scale height `meters`.
  static DensityProfile exponential(double scaleHeightMeters) noexcept;
};

/// What an atmosphere is made of. Coefficients per metre, for R, G and B.
struct AtmosphereParameters final {
  glm::dvec3 solarIrradiance{0.0};     ///< at the top of the atmosphere
  double sunAngularRadius = 0.004675;  ///< radians
  double bottomRadius = 0.0;           ///< the planet's (mean) radius
  double topRadius = 0.0;              ///< where the atmosphere is taken to end
  DensityProfile rayleighDensity;      ///< molecules' density with altitude
  glm::dvec3 rayleighScattering{0.0};  ///< molecules' scattering at the bottom, per metre
  DensityProfile mieDensity;           ///< aerosols' (dust's) density with altitude
  glm::dvec3 mieScattering{0.0};       ///< aerosols' scattering at the bottom, per metre
  glm::dvec3 mieExtinction{0.0};       ///< aerosols' scattering plus absorption, per metre
  /// Asymmetry of Mie scattering (Cornette–Shanks phase function) per channel: dust scatters
  /// blue further forward than red (Mars's blue sunsets).
  glm::dvec3 miePhaseG{0.8};
  DensityProfile absorptionDensity;      ///< an absorbing layer's density (Earth's ozone)
  glm::dvec3 absorptionExtinction{0.0};  ///< its absorption at density 1, per metre
  glm::dvec3 groundAlbedo{0.1};          ///< the ground's mean reflectance (multiple scattering)
  /// The cosine of the largest sun zenith angle the tables cover (below it the sky is dark).
  double muSMin = -0.2;

  /// Earth: Rayleigh (scale height 8 km), Mie aerosols (1.2 km, g = 0.8) and ozone (a tent
  /// profile peaking at 25 km), the values of Bruneton's 2017 demo, on a sphere of the mean
  /// radius 6,371 km.
  static AtmosphereParameters earth();
  /// Mars: a thin CO₂ Rayleigh atmosphere (6 mbar: 4% of Earth's scattering, scale height 11.1 km)
  /// and suspended dust (optical depth 0.5, scale height 11.1 km, single-scattering albedo 0.97 /
  /// 0.90 / 0.74 and g 0.63 / 0.70 / 0.78 for R / G / B: it absorbs blue and scatters it
  /// forward), sunlight at 1.524 AU.
  static AtmosphereParameters mars();
  /// The atmosphere of `planet`'s body (SolarBody): Earth's or Mars's, its bottom the reference
  /// surface's equatorial radius; nullopt for the others.
  static std::optional<AtmosphereParameters> of(const Planet& planet);
};

/// Table sizes. The scattering tables are 4D (r, μ, μ_s, ν), stored as a 3D texture of width
/// nu·muS, height mu and depth r, as in Bruneton's implementation.
struct AtmosphereTableSizes final {
  std::uint32_t transmittanceWidth = 256;  ///< μ
  std::uint32_t transmittanceHeight = 64;  ///< r
  std::uint32_t scatteringR = 32;          ///< radii (layers)
  std::uint32_t scatteringMu = 128;        ///< even: half below the horizon, half above
  std::uint32_t scatteringMuS = 32;        ///< sun zenith angles
  std::uint32_t scatteringNu = 8;          ///< angles between the view and the sun
  std::uint32_t irradianceWidth = 64;      ///< μ_s
  std::uint32_t irradianceHeight = 16;     ///< r
  std::uint32_t scatteringOrders = 4;      ///< 1: single scattering only
};

/// A table of RGB floats with linear filtering and clamp-to-edge addressing like a GPU texture:
/// texel i's centre at (i + 0.5) / size.
struct AtmosphereTable final {
  std::uint32_t width = 0;   ///< texels a row
  std::uint32_t height = 0;  ///< rows a layer
  std::uint32_t depth = 1;   ///< layers
  std::vector<float> rgb;    ///< width · height · depth · 3, x fastest

  /// Texel (x, y) of layer z.
  glm::dvec3 texel(std::uint32_t x, std::uint32_t y, std::uint32_t z = 0) const noexcept;
  /// Bilinear (depth 1) or trilinear sample at texture coordinates in [0, 1].
  glm::dvec3 sample(double u, double v, double w = 0.5) const noexcept;
};

/// The precomputed tables of one atmosphere.
class AtmosphereTables final {
 public:
  /// Computes the tables (in parallel with TBB; the same floats whatever the thread count).
  static AtmosphereTables compute(const AtmosphereParameters& parameters,
                                  const AtmosphereTableSizes& sizes = {});
  /// The tables of `parameters` and `sizes` from the cache file `path` when it holds them (its
  /// head: both, byte for byte), else computed and written there (atomically; a failure to write is
  /// not an error: the tables are returned). `computed` says which happened.
  static AtmosphereTables cached(const std::filesystem::path& path,
                                 const AtmosphereParameters& parameters,
                                 const AtmosphereTableSizes& sizes, bool* computed = nullptr);

  /// What the tables were computed for.
  const AtmosphereParameters& parameters() const noexcept { return parameters_; }
  /// Their sizes.
  const AtmosphereTableSizes& sizes() const noexcept { return sizes_; }
  /// Transmittance to the top of the atmosphere, (μ, r).
  const AtmosphereTable& transmittance() const noexcept { return transmittance_; }
  /// Rayleigh single scattering plus all multiple scattering (divided by the Rayleigh phase
  /// function), without the solar phase factors.
  const AtmosphereTable& scattering() const noexcept { return scattering_; }
  /// Mie single scattering, without its phase function.
  const AtmosphereTable& singleMieScattering() const noexcept { return singleMie_; }
  /// Irradiance of the ground by the sky (not the sun), (μ_s, r).
  const AtmosphereTable& irradiance() const noexcept { return irradiance_; }

  /// Transmittance from radius r along the direction of cosine μ (to the zenith) to the top of
  /// the atmosphere (the tables' interpolation).
  glm::dvec3 transmittanceToTop(double r, double mu) const noexcept;
  /// Transmittance of sunlight reaching radius r with the sun at cosine μ_s, the sun's disc
  /// partly below the horizon counted.
  glm::dvec3 transmittanceToSun(double r, double muS) const noexcept;

  /// What a view ray sees of the atmosphere.
  struct Radiance final {
    glm::dvec3 radiance{0.0};       ///< in-scattered radiance towards the camera
    glm::dvec3 transmittance{1.0};  ///< along the ray (to a point; to space for the sky)
  };
  /// The sky's radiance along `viewRay` (unit) from `camera` (planet-centred), the sun towards
  /// `sunDirection` (unit); the sun's disc itself is not included. Transmittance 0 where the ray
  /// meets the ground.
  Radiance skyRadiance(const glm::dvec3& camera, const glm::dvec3& viewRay,
                       const glm::dvec3& sunDirection) const noexcept;
  /// The aerial perspective between `camera` and `point`: the radiance scattered in towards the
  /// camera along the segment, and its transmittance.
  Radiance skyRadianceToPoint(const glm::dvec3& camera, const glm::dvec3& point,
                              const glm::dvec3& sunDirection) const noexcept;
  /// Irradiance of a surface by the sun and by the sky.
  struct Irradiance final {
    glm::dvec3 sun{0.0};  ///< the sun's, through the air, times the cosine with the normal
    glm::dvec3 sky{0.0};  ///< the sky's
  };
  /// The sun's and the sky's irradiance at `point` on a surface of unit `normal`.
  Irradiance sunAndSkyIrradiance(const glm::dvec3& point, const glm::dvec3& normal,
                                 const glm::dvec3& sunDirection) const noexcept;
  /// The radiance of the sun's disc seen through the whole atmosphere from `camera` towards the
  /// sun (zero when the ground is in the way).
  glm::dvec3 sunRadiance(const glm::dvec3& camera, const glm::dvec3& sunDirection) const noexcept;

 private:
  AtmosphereParameters parameters_;
  AtmosphereTableSizes sizes_;
  AtmosphereTable transmittance_;
  AtmosphereTable scattering_;
  AtmosphereTable singleMie_;
  AtmosphereTable irradiance_;
};

}  // namespace pbdam::runtime
