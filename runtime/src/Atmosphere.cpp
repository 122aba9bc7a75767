// Precomputed atmospheric scattering (Atmosphere.h). The table parametrisations and the order of
// the precomputation follow Bruneton's 2017 reference implementation ("Precomputed Atmospheric
// Scattering: a New Implementation"), written here for the host: transmittance, direct ground
// irradiance, single scattering, then per order the scattering density, the ground irradiance it
// gives and the multiple scattering it adds.
#include "pbdam/runtime/Atmosphere.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <glm/geometric.hpp>
#include <numbers>

#include "pbdam/runtime/Sun.h"

namespace pbdam::runtime {
namespace {

constexpr double kPi = std::numbers::pi;
using Vec3 = glm::dvec3;

double clampCosine(double mu) { return std::clamp(mu, -1.0, 1.0); }
double safeSqrt(double a) { return std::sqrt(std::max(a, 0.0)); }

double textureCoordFromUnitRange(double x, std::uint32_t size) {
  return 0.5 / size + x * (1.0 - 1.0 / size);
}
double unitRangeFromTextureCoord(double u, std::uint32_t size) {
  return (u - 0.5 / size) / (1.0 - 1.0 / size);
}

double smoothstep(double edge0, double edge1, double x) {
  const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

double rayleighPhase(double nu) { return 3.0 / (16.0 * kPi) * (1.0 + nu * nu); }

Vec3 miePhase(const Vec3& g, double nu) {
  Vec3 out;
  for (int c = 0; c < 3; ++c) {
    const double k = 3.0 / (8.0 * kPi) * (1.0 - g[c] * g[c]) / (2.0 + g[c] * g[c]);
    const double base = 1.0 + g[c] * g[c] - 2.0 * g[c] * nu;
    out[c] = k * (1.0 + nu * nu) / (base * std::sqrt(base));
  }
  return out;
}

Vec3 exp3(const Vec3& v) { return {std::exp(v.x), std::exp(v.y), std::exp(v.z)}; }

/// The geometry of the atmosphere shared by every function below.
struct Shell final {
  const AtmosphereParameters& p;
  const AtmosphereTableSizes& s;

  double clampRadius(double r) const { return std::clamp(r, p.bottomRadius, p.topRadius); }
  double horizonLength() const { return std::sqrt(sq(p.topRadius) - sq(p.bottomRadius)); }
  static double sq(double x) { return x * x; }

  double distanceToTop(double r, double mu) const {
    return std::max(0.0, -r * mu + safeSqrt(r * r * (mu * mu - 1.0) + sq(p.topRadius)));
  }
  double distanceToBottom(double r, double mu) const {
    return std::max(0.0, -r * mu - safeSqrt(r * r * (mu * mu - 1.0) + sq(p.bottomRadius)));
  }
  bool rayIntersectsGround(double r, double mu) const {
    return mu < 0.0 && r * r * (mu * mu - 1.0) + sq(p.bottomRadius) >= 0.0;
  }
  double distanceToNearestBoundary(double r, double mu, bool ground) const {
    return ground ? distanceToBottom(r, mu) : distanceToTop(r, mu);
  }

  // --- transmittance table: (μ, r) ---
  std::pair<double, double> transmittanceUv(double r, double mu) const {
    const double h = horizonLength();
    const double rho = safeSqrt(r * r - sq(p.bottomRadius));
    const double d = distanceToTop(r, mu);
    const double dMin = p.topRadius - r;
    const double dMax = rho + h;
    const double xMu = dMax == dMin ? 0.0 : (d - dMin) / (dMax - dMin);
    const double xR = rho / h;
    return {textureCoordFromUnitRange(xMu, s.transmittanceWidth),
            textureCoordFromUnitRange(xR, s.transmittanceHeight)};
  }
  std::pair<double, double> rMuFromTransmittanceUv(double u, double v) const {
    const double xMu = unitRangeFromTextureCoord(u, s.transmittanceWidth);
    const double xR = unitRangeFromTextureCoord(v, s.transmittanceHeight);
    const double h = horizonLength();
    const double rho = h * xR;
    const double r = std::sqrt(rho * rho + sq(p.bottomRadius));
    const double dMin = p.topRadius - r;
    const double dMax = rho + h;
    const double d = dMin + xMu * (dMax - dMin);
    const double mu = d == 0.0 ? 1.0 : (h * h - rho * rho - d * d) / (2.0 * r * d);
    return {r, clampCosine(mu)};
  }

  double opticalLengthToTop(const DensityProfile& profile, double r, double mu) const {
    constexpr int kSamples = 500;
    const double dx = distanceToTop(r, mu) / kSamples;
    double result = 0.0;
    for (int i = 0; i <= kSamples; ++i) {
      const double di = i * dx;
      const double ri = std::sqrt(di * di + 2.0 * r * mu * di + r * r);
      const double weight = i == 0 || i == kSamples ? 0.5 : 1.0;
      result += profile.at(ri - p.bottomRadius) * weight * dx;
    }
    return result;
  }

  // --- scattering table: (r, μ, μ_s, ν) ---
  struct Uvwz final {
    double u = 0.0;  ///< ν
    double v = 0.0;  ///< μ_s
    double w = 0.0;  ///< μ
    double z = 0.0;  ///< r
  };
  double muSUnit(double muS) const {
    const double dMin = p.topRadius - p.bottomRadius;
    const double dMax = horizonLength();
    const double a = (distanceToTop(p.bottomRadius, muS) - dMin) / (dMax - dMin);
    const double big = (distanceToTop(p.bottomRadius, p.muSMin) - dMin) / (dMax - dMin);
    return std::max(1.0 - a / big, 0.0) / (1.0 + a);
  }
  Uvwz scatteringUvwz(double r, double mu, double muS, double nu, bool ground) const {
    const double h = horizonLength();
    const double rho = safeSqrt(r * r - sq(p.bottomRadius));
    Uvwz t;
    t.z = textureCoordFromUnitRange(rho / h, s.scatteringR);
    const double rMu = r * mu;
    const double disc = rMu * rMu - r * r + sq(p.bottomRadius);
    const std::uint32_t halfMu = s.scatteringMu / 2;
    if (ground) {
      const double d = -rMu - safeSqrt(disc);
      const double dMin = r - p.bottomRadius;
      const double dMax = rho;
      t.w = 0.5 - 0.5 * textureCoordFromUnitRange(dMax == dMin ? 0.0 : (d - dMin) / (dMax - dMin),
                                                  halfMu);
    } else {
      const double d = -rMu + safeSqrt(disc + h * h);
      const double dMin = p.topRadius - r;
      const double dMax = rho + h;
      t.w = 0.5 + 0.5 * textureCoordFromUnitRange((d - dMin) / (dMax - dMin), halfMu);
    }
    t.v = textureCoordFromUnitRange(muSUnit(muS), s.scatteringMuS);
    t.u = (nu + 1.0) / 2.0;
    return t;
  }
  struct RMuMuSNu final {
    double r = 0.0;
    double mu = 0.0;
    double muS = 0.0;
    double nu = 0.0;
    bool ground = false;
  };
  RMuMuSNu rMuMuSNuFromUvwz(const Uvwz& t) const {
    const double h = horizonLength();
    RMuMuSNu out;
    const double rho = h * unitRangeFromTextureCoord(t.z, s.scatteringR);
    out.r = std::sqrt(rho * rho + sq(p.bottomRadius));
    const std::uint32_t halfMu = s.scatteringMu / 2;
    if (t.w < 0.5) {
      const double dMin = out.r - p.bottomRadius;
      const double dMax = rho;
      const double d = dMin + (dMax - dMin) * unitRangeFromTextureCoord(1.0 - 2.0 * t.w, halfMu);
      out.mu = d == 0.0 ? -1.0 : clampCosine(-(rho * rho + d * d) / (2.0 * out.r * d));
      out.ground = true;
    } else {
      const double dMin = p.topRadius - out.r;
      const double dMax = rho + h;
      const double d = dMin + (dMax - dMin) * unitRangeFromTextureCoord(2.0 * t.w - 1.0, halfMu);
      out.mu = d == 0.0 ? 1.0 : clampCosine((h * h - rho * rho - d * d) / (2.0 * out.r * d));
      out.ground = false;
    }
    const double xMuS = unitRangeFromTextureCoord(t.v, s.scatteringMuS);
    const double dMin = p.topRadius - p.bottomRadius;
    const double dMax = h;
    const double big = (distanceToTop(p.bottomRadius, p.muSMin) - dMin) / (dMax - dMin);
    const double a = (big - xMuS * big) / (1.0 + xMuS * big);
    const double d = dMin + std::min(a, big) * (dMax - dMin);
    out.muS = d == 0.0 ? 1.0 : clampCosine((h * h - d * d) / (2.0 * p.bottomRadius * d));
    out.nu = clampCosine(t.u * 2.0 - 1.0);
    return out;
  }
  /// The (r, μ, μ_s, ν) of texel (x, y, z) of a scattering table.
  RMuMuSNu texelParameters(std::uint32_t x, std::uint32_t y, std::uint32_t z) const {
    const double nuTexel = std::floor(static_cast<double>(x) / s.scatteringMuS);
    const double muSTexel = std::fmod(static_cast<double>(x), static_cast<double>(s.scatteringMuS));
    Uvwz t;
    t.u = nuTexel / (s.scatteringNu - 1);
    t.v = (muSTexel + 0.5) / s.scatteringMuS;
    t.w = (y + 0.5) / s.scatteringMu;
    t.z = (z + 0.5) / s.scatteringR;
    RMuMuSNu out = rMuMuSNuFromUvwz(t);
    out.nu = std::clamp(
        out.nu, out.mu * out.muS - safeSqrt((1.0 - out.mu * out.mu) * (1.0 - out.muS * out.muS)),
        out.mu * out.muS + safeSqrt((1.0 - out.mu * out.mu) * (1.0 - out.muS * out.muS)));
    return out;
  }

  // --- irradiance table: (μ_s, r) ---
  std::pair<double, double> irradianceUv(double r, double muS) const {
    const double xR = (r - p.bottomRadius) / (p.topRadius - p.bottomRadius);
    const double xMuS = muS * 0.5 + 0.5;
    return {textureCoordFromUnitRange(xMuS, s.irradianceWidth),
            textureCoordFromUnitRange(xR, s.irradianceHeight)};
  }
  std::pair<double, double> rMuSFromIrradianceUv(double u, double v) const {
    const double xMuS = unitRangeFromTextureCoord(u, s.irradianceWidth);
    const double xR = unitRangeFromTextureCoord(v, s.irradianceHeight);
    return {p.bottomRadius + xR * (p.topRadius - p.bottomRadius), clampCosine(2.0 * xMuS - 1.0)};
  }
};

/// Lookups into tables being made (or made).
struct Lookup final {
  const Shell& shell;
  const AtmosphereTable& transmittanceTable;

  Vec3 transmittanceToTop(double r, double mu) const {
    const auto [u, v] = shell.transmittanceUv(r, mu);
    return transmittanceTable.sample(u, v);
  }
  Vec3 transmittance(double r, double mu, double d, bool ground) const {
    const double rD = shell.clampRadius(std::sqrt(d * d + 2.0 * r * mu * d + r * r));
    const double muD = clampCosine((r * mu + d) / rD);
    if (ground) {
      return glm::min(transmittanceToTop(rD, -muD) / transmittanceToTop(r, -mu), Vec3(1.0));
    }
    return glm::min(transmittanceToTop(r, mu) / transmittanceToTop(rD, muD), Vec3(1.0));
  }
  Vec3 transmittanceToSun(double r, double muS) const {
    const double sinH = shell.p.bottomRadius / r;
    const double cosH = -safeSqrt(1.0 - sinH * sinH);
    const double a = sinH * shell.p.sunAngularRadius;
    return transmittanceToTop(r, muS) * smoothstep(-a, a, muS - cosH);
  }
  /// A 4D scattering table at (r, μ, μ_s, ν): two trilinear samples blended along ν.
  Vec3 scattering(const AtmosphereTable& table, double r, double mu, double muS, double nu,
                  bool ground) const {
    const Shell::Uvwz t = shell.scatteringUvwz(r, mu, muS, nu, ground);
    const double x = t.u * (shell.s.scatteringNu - 1);
    const double texX = std::floor(x);
    const double lerp = x - texX;
    const double n = shell.s.scatteringNu;
    const Vec3 a = table.sample((texX + t.v) / n, t.w, t.z);
    const Vec3 b = table.sample((texX + 1.0 + t.v) / n, t.w, t.z);
    return a * (1.0 - lerp) + b * lerp;
  }
  Vec3 irradiance(const AtmosphereTable& table, double r, double muS) const {
    const auto [u, v] = shell.irradianceUv(r, muS);
    return table.sample(u, v);
  }
};

AtmosphereTable makeTable(std::uint32_t w, std::uint32_t h, std::uint32_t d = 1) {
  AtmosphereTable t;
  t.width = w;
  t.height = h;
  t.depth = d;
  t.rgb.assign(static_cast<std::size_t>(w) * h * d * 3, 0.0f);
  return t;
}

void store(AtmosphereTable& t, std::size_t index, const Vec3& v) {
  t.rgb[index * 3] = static_cast<float>(v.x);
  t.rgb[index * 3 + 1] = static_cast<float>(v.y);
  t.rgb[index * 3 + 2] = static_cast<float>(v.z);
}

/// Runs fn(x, y, z, index) over every texel, rows in parallel.
template <typename Fn>
void forEachTexel(AtmosphereTable& t, Fn&& fn) {
  const std::size_t rows = static_cast<std::size_t>(t.height) * t.depth;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows), [&](const auto& range) {
    for (std::size_t row = range.begin(); row != range.end(); ++row) {
      const auto y = static_cast<std::uint32_t>(row % t.height);
      const auto z = static_cast<std::uint32_t>(row / t.height);
      for (std::uint32_t x = 0; x < t.width; ++x) {
        fn(x, y, z, row * t.width + x);
      }
    }
  });
}

}  // namespace

double DensityProfile::at(double altitudeMeters) const noexcept {
  const DensityLayer& l = altitudeMeters < layers[0].widthMeters ? layers[0] : layers[1];
  const double d = l.expTerm * std::exp(l.expScale * altitudeMeters) +
                   l.linearTerm * altitudeMeters + l.constantTerm;
  return std::clamp(d, 0.0, 1.0);
}

DensityProfile DensityProfile::exponential(double scaleHeightMeters) noexcept {
  DensityProfile p;
  p.layers[1] = {0.0, 1.0, -1.0 / scaleHeightMeters, 0.0, 0.0};
  return p;
}

AtmosphereParameters AtmosphereParameters::earth() {
  AtmosphereParameters a;
  a.solarIrradiance = {1.474, 1.8504, 1.91198};
  a.sunAngularRadius = sunAngularRadiusRadians(1.0);
  a.bottomRadius = 6371e3;
  a.topRadius = 6371e3 + 60e3;
  a.rayleighDensity = DensityProfile::exponential(8000.0);
  a.rayleighScattering = {5.802e-6, 13.558e-6, 33.1e-6};
  a.mieDensity = DensityProfile::exponential(1200.0);
  a.mieScattering = Vec3(3.996e-6);
  a.mieExtinction = Vec3(4.40e-6);
  a.miePhaseG = Vec3(0.8);
  // Ozone: a tent from 10 to 40 km peaking at 25 km.
  a.absorptionDensity.layers[0] = {25e3, 0.0, 0.0, 1.0 / 15e3, -2.0 / 3.0};
  a.absorptionDensity.layers[1] = {0.0, 0.0, 0.0, -1.0 / 15e3, 8.0 / 3.0};
  a.absorptionExtinction = {0.650e-6, 1.881e-6, 0.085e-6};
  a.groundAlbedo = Vec3(0.1);
  a.muSMin = std::cos(102.0 * kPi / 180.0);
  return a;
}

AtmosphereParameters AtmosphereParameters::mars() {
  constexpr double kDistanceAu = 1.5237;
  constexpr double kScaleHeight = 11.1e3;
  constexpr double kDustOpticalDepth = 0.5;
  AtmosphereParameters a;
  a.solarIrradiance = Vec3(1.474, 1.8504, 1.91198) / (kDistanceAu * kDistanceAu);
  a.sunAngularRadius = sunAngularRadiusRadians(kDistanceAu);
  a.bottomRadius = 3389.5e3;
  a.topRadius = 3389.5e3 + 90e3;
  a.rayleighDensity = DensityProfile::exponential(kScaleHeight);
  a.rayleighScattering = Vec3(5.802e-6, 13.558e-6, 33.1e-6) * 0.041;
  a.mieDensity = DensityProfile::exponential(kScaleHeight);
  const double extinction = kDustOpticalDepth / kScaleHeight;
  a.mieExtinction = Vec3(extinction);
  a.mieScattering = Vec3(0.97, 0.90, 0.74) * extinction;
  a.miePhaseG = {0.63, 0.70, 0.78};
  a.absorptionExtinction = Vec3(0.0);
  a.groundAlbedo = Vec3(0.25);
  a.muSMin = std::cos(102.0 * kPi / 180.0);
  return a;
}

std::optional<AtmosphereParameters> AtmosphereParameters::of(const Planet& planet) {
  std::optional<AtmosphereParameters> a;
  switch (solarBodyOf(planet)) {
    case SolarBody::Earth:
      a = earth();
      break;
    case SolarBody::Mars:
      a = mars();
      break;
    case SolarBody::None:
      return std::nullopt;
  }
  // The bottom sphere is the reference surface's equatorial radius: the renderer stretches an
  // ellipsoid along its polar axis onto it.
  const double thickness = a->topRadius - a->bottomRadius;
  a->bottomRadius = planet.equatorialRadiusMeters();
  a->topRadius = a->bottomRadius + thickness;
  return a;
}

glm::dvec3 AtmosphereTable::texel(std::uint32_t x, std::uint32_t y,
                                  std::uint32_t z) const noexcept {
  const std::size_t i = ((static_cast<std::size_t>(z) * height + y) * width + x) * 3;
  return {static_cast<double>(rgb[i]), static_cast<double>(rgb[i + 1]),
          static_cast<double>(rgb[i + 2])};
}

glm::dvec3 AtmosphereTable::sample(double u, double v, double w) const noexcept {
  struct Axis {
    std::size_t i0 = 0;
    std::size_t i1 = 0;
    double f = 0.0;
  };
  const auto axis = [](double t, std::uint32_t size) {
    const double x = std::clamp(t * size - 0.5, 0.0, static_cast<double>(size - 1));
    const double fl = std::floor(x);
    Axis a;
    a.i0 = static_cast<std::size_t>(fl);
    a.i1 = std::min<std::size_t>(a.i0 + 1, size - 1);
    a.f = x - fl;
    return a;
  };
  const Axis ax = axis(u, width);
  const Axis ay = axis(v, height);
  const Axis az = axis(w, depth);
  const float* data = rgb.data();
  const std::size_t rowStride = static_cast<std::size_t>(width) * 3;
  const std::size_t planeStride = rowStride * height;
  const auto plane = [&](std::size_t z) {
    const float* row0 = data + z * planeStride + ay.i0 * rowStride;
    const float* row1 = data + z * planeStride + ay.i1 * rowStride;
    Vec3 out;
    for (std::size_t c = 0; c < 3; ++c) {
      const auto a00 = static_cast<double>(row0[ax.i0 * 3 + c]);
      const auto a01 = static_cast<double>(row0[ax.i1 * 3 + c]);
      const auto a10 = static_cast<double>(row1[ax.i0 * 3 + c]);
      const auto a11 = static_cast<double>(row1[ax.i1 * 3 + c]);
      const double a = a00 + (a01 - a00) * ax.f;
      const double b = a10 + (a11 - a10) * ax.f;
      out[static_cast<int>(c)] = a + (b - a) * ay.f;
    }
    return out;
  };
  if (depth == 1) return plane(0);
  const Vec3 a = plane(az.i0);
  return a + (plane(az.i1) - a) * az.f;
}

namespace {

/// Transmittance to the top of the atmosphere, (μ, r).
void computeTransmittance(const Shell& shell, AtmosphereTable& out) {
  const AtmosphereParameters& p = shell.p;
  forEachTexel(out, [&](std::uint32_t x, std::uint32_t y, std::uint32_t, std::size_t i) {
    const auto [r, mu] = shell.rMuFromTransmittanceUv((x + 0.5) / shell.s.transmittanceWidth,
                                                      (y + 0.5) / shell.s.transmittanceHeight);
    const Vec3 depth =
        p.rayleighScattering * shell.opticalLengthToTop(p.rayleighDensity, r, mu) +
        p.mieExtinction * shell.opticalLengthToTop(p.mieDensity, r, mu) +
        p.absorptionExtinction * shell.opticalLengthToTop(p.absorptionDensity, r, mu);
    store(out, i, exp3(-depth));
  });
}

/// The sun's irradiance of the ground through the air, (μ_s, r): only for the next orders (the
/// shaders add the sun's own light themselves).
void computeDirectIrradiance(const Shell& shell, const Lookup& look, AtmosphereTable& out) {
  const AtmosphereParameters& p = shell.p;
  forEachTexel(out, [&](std::uint32_t x, std::uint32_t y, std::uint32_t, std::size_t i) {
    const auto [r, muS] = shell.rMuSFromIrradianceUv((x + 0.5) / shell.s.irradianceWidth,
                                                     (y + 0.5) / shell.s.irradianceHeight);
    const double a = p.sunAngularRadius;
    const double cosineFactor =
        muS < -a ? 0.0 : (muS > a ? muS : (muS + a) * (muS + a) / (4.0 * a));
    store(out, i, p.solarIrradiance * look.transmittanceToTop(r, muS) * cosineFactor);
  });
}

/// Single Rayleigh and Mie scattering, without their phase functions.
void computeSingleScattering(const Shell& shell, const Lookup& look, AtmosphereTable& rayleighOut,
                             AtmosphereTable& mieOut) {
  const AtmosphereParameters& p = shell.p;
  forEachTexel(rayleighOut, [&](std::uint32_t x, std::uint32_t y, std::uint32_t z, std::size_t i) {
    const Shell::RMuMuSNu q = shell.texelParameters(x, y, z);
    constexpr int kSamples = 50;
    const double dx = shell.distanceToNearestBoundary(q.r, q.mu, q.ground) / kSamples;
    Vec3 rayleigh(0.0);
    Vec3 mie(0.0);
    for (int k = 0; k <= kSamples; ++k) {
      const double d = k * dx;
      const double rD = shell.clampRadius(std::sqrt(d * d + 2.0 * q.r * q.mu * d + q.r * q.r));
      const double muSD = clampCosine((q.r * q.muS + d * q.nu) / rD);
      const Vec3 t = look.transmittance(q.r, q.mu, d, q.ground) * look.transmittanceToSun(rD, muSD);
      const double weight = k == 0 || k == kSamples ? 0.5 : 1.0;
      rayleigh += t * p.rayleighDensity.at(rD - p.bottomRadius) * weight;
      mie += t * p.mieDensity.at(rD - p.bottomRadius) * weight;
    }
    store(rayleighOut, i, rayleigh * dx * p.solarIrradiance * p.rayleighScattering);
    store(mieOut, i, mie * dx * p.solarIrradiance * p.mieScattering);
  });
}

/// The light the previous order scatters towards (r, μ) with the sun at μ_s, ν: single
/// scattering with its phase functions after the first order, else the previous multiple order.
struct Incoming final {
  const Lookup& look;
  const AtmosphereTable& rayleigh;
  const AtmosphereTable& mie;
  const AtmosphereTable& multiple;
  bool afterSingle = true;

  Vec3 operator()(double r, double mu, double muS, double nu, bool ground) const {
    if (afterSingle) {
      return look.scattering(rayleigh, r, mu, muS, nu, ground) * rayleighPhase(nu) +
             look.scattering(mie, r, mu, muS, nu, ground) * miePhase(look.shell.p.miePhaseG, nu);
    }
    return look.scattering(multiple, r, mu, muS, nu, ground);
  }
};

/// The directions (θ, φ) of the sphere the scattering density integrates over.
constexpr std::size_t kThetaSamples = 8;
constexpr double kDTheta = kPi / static_cast<double>(kThetaSamples);
struct SphereDirections final {
  std::array<double, kThetaSamples> cosTheta{};
  std::array<double, kThetaSamples> sinTheta{};
  std::array<double, 2 * kThetaSamples> cosPhi{};
  std::array<double, 2 * kThetaSamples> sinPhi{};
};

SphereDirections sphereDirections() {
  SphereDirections sphere;
  for (std::size_t l = 0; l < kThetaSamples; ++l) {
    sphere.cosTheta[l] = std::cos((static_cast<double>(l) + 0.5) * kDTheta);
    sphere.sinTheta[l] = std::sin((static_cast<double>(l) + 0.5) * kDTheta);
  }
  for (std::size_t m = 0; m < 2 * kThetaSamples; ++m) {
    sphere.cosPhi[m] = std::cos((static_cast<double>(m) + 0.5) * kDTheta);
    sphere.sinPhi[m] = std::sin((static_cast<double>(m) + 0.5) * kDTheta);
  }
  return sphere;
}

/// The light scattered at each (r, μ, μ_s, ν) by the previous order's light, including what the
/// ground reflects of its irradiance `groundIrradiance`.
void computeScatteringDensity(const Shell& shell, const Lookup& look, const Incoming& incoming,
                              const AtmosphereTable& groundIrradiance, AtmosphereTable& out) {
  const AtmosphereParameters& p = shell.p;
  const SphereDirections sphere = sphereDirections();
  forEachTexel(out, [&](std::uint32_t x, std::uint32_t y, std::uint32_t z, std::size_t i) {
    const Shell::RMuMuSNu q = shell.texelParameters(x, y, z);
    const Vec3 zenith(0.0, 0.0, 1.0);
    const Vec3 omega(safeSqrt(1.0 - q.mu * q.mu), 0.0, q.mu);
    const double sunX = omega.x == 0.0 ? 0.0 : (q.nu - q.mu * q.muS) / omega.x;
    const Vec3 omegaS(sunX, safeSqrt(1.0 - sunX * sunX - q.muS * q.muS), q.muS);
    const double altitude = q.r - p.bottomRadius;
    Vec3 result(0.0);
    for (std::size_t l = 0; l < kThetaSamples; ++l) {
      const double cosTheta = sphere.cosTheta[l];
      const double sinTheta = sphere.sinTheta[l];
      const bool ground = shell.rayIntersectsGround(q.r, cosTheta);
      Vec3 groundTransmittance(0.0);
      double distanceToGround = 0.0;
      if (ground) {
        distanceToGround = shell.distanceToBottom(q.r, cosTheta);
        groundTransmittance = look.transmittance(q.r, cosTheta, distanceToGround, true);
      }
      for (std::size_t m = 0; m < 2 * kThetaSamples; ++m) {
        const Vec3 omegaI(sphere.cosPhi[m] * sinTheta, sphere.sinPhi[m] * sinTheta, cosTheta);
        const double dOmega = kDTheta * kDTheta * sinTheta;
        Vec3 radiance = incoming(q.r, omegaI.z, q.muS, glm::dot(omegaS, omegaI), ground);
        if (ground) {
          const Vec3 normal = glm::normalize(zenith * q.r + omegaI * distanceToGround);
          const Vec3 irradiance =
              look.irradiance(groundIrradiance, p.bottomRadius, glm::dot(normal, omegaS));
          radiance += groundTransmittance * p.groundAlbedo * (1.0 / kPi) * irradiance;
        }
        const double nu2 = glm::dot(omega, omegaI);
        result += radiance *
                  (p.rayleighScattering * p.rayleighDensity.at(altitude) * rayleighPhase(nu2) +
                   p.mieScattering * p.mieDensity.at(altitude) * miePhase(p.miePhaseG, nu2)) *
                  dOmega;
      }
    }
    store(out, i, result);
  });
}

/// The sky's irradiance of the ground from the previous order's light, (μ_s, r).
void computeIndirectIrradiance(const Shell& shell, const Incoming& incoming, AtmosphereTable& out) {
  forEachTexel(out, [&](std::uint32_t x, std::uint32_t y, std::uint32_t, std::size_t i) {
    const auto [r, muS] = shell.rMuSFromIrradianceUv((x + 0.5) / shell.s.irradianceWidth,
                                                     (y + 0.5) / shell.s.irradianceHeight);
    constexpr int kSamples = 16;
    constexpr double dPhi = kPi / kSamples;
    constexpr double dTheta = kPi / kSamples;
    const Vec3 omegaS(safeSqrt(1.0 - muS * muS), 0.0, muS);
    Vec3 result(0.0);
    for (int j = 0; j < kSamples / 2; ++j) {
      const double theta = (j + 0.5) * dTheta;
      for (int k = 0; k < 2 * kSamples; ++k) {
        const double phi = (k + 0.5) * dPhi;
        const Vec3 omega(std::cos(phi) * std::sin(theta), std::sin(phi) * std::sin(theta),
                         std::cos(theta));
        const double dOmega = dTheta * dPhi * std::sin(theta);
        result += incoming(r, omega.z, muS, glm::dot(omega, omegaS), false) * omega.z * dOmega;
      }
    }
    store(out, i, result);
  });
}

/// This order's scattering, the density integrated along each ray, into `delta`; added to
/// `accumulated` divided by the Rayleigh phase function (the shaders multiply it back).
void computeMultipleScattering(const Shell& shell, const Lookup& look,
                               const AtmosphereTable& density, AtmosphereTable& delta,
                               AtmosphereTable& accumulated) {
  forEachTexel(delta, [&](std::uint32_t x, std::uint32_t y, std::uint32_t z, std::size_t i) {
    const Shell::RMuMuSNu q = shell.texelParameters(x, y, z);
    constexpr int kSamples = 50;
    const double dx = shell.distanceToNearestBoundary(q.r, q.mu, q.ground) / kSamples;
    Vec3 sum(0.0);
    for (int k = 0; k <= kSamples; ++k) {
      const double d = k * dx;
      const double rI = shell.clampRadius(std::sqrt(d * d + 2.0 * q.r * q.mu * d + q.r * q.r));
      const double muI = clampCosine((q.r * q.mu + d) / rI);
      const double muSI = clampCosine((q.r * q.muS + d * q.nu) / rI);
      const double weight = k == 0 || k == kSamples ? 0.5 : 1.0;
      sum += look.scattering(density, rI, muI, muSI, q.nu, q.ground) *
             look.transmittance(q.r, q.mu, d, q.ground) * dx * weight;
    }
    store(delta, i, sum);
    const double phase = rayleighPhase(q.nu);
    for (std::size_t c = 0; c < 3; ++c) {
      accumulated.rgb[i * 3 + c] += static_cast<float>(sum[static_cast<int>(c)] / phase);
    }
  });
}

}  // namespace

AtmosphereTables AtmosphereTables::compute(const AtmosphereParameters& parameters,
                                           const AtmosphereTableSizes& sizes) {
  AtmosphereTables out;
  out.parameters_ = parameters;
  out.sizes_ = sizes;
  const AtmosphereTableSizes& s = out.sizes_;
  const Shell shell{out.parameters_, s};
  out.transmittance_ = makeTable(s.transmittanceWidth, s.transmittanceHeight);
  computeTransmittance(shell, out.transmittance_);
  const Lookup look{shell, out.transmittance_};
  AtmosphereTable deltaIrradiance = makeTable(s.irradianceWidth, s.irradianceHeight);
  computeDirectIrradiance(shell, look, deltaIrradiance);
  out.irradiance_ = makeTable(s.irradianceWidth, s.irradianceHeight);
  const std::uint32_t scatterWidth = s.scatteringNu * s.scatteringMuS;
  AtmosphereTable deltaRayleigh = makeTable(scatterWidth, s.scatteringMu, s.scatteringR);
  out.singleMie_ = makeTable(scatterWidth, s.scatteringMu, s.scatteringR);
  computeSingleScattering(shell, look, deltaRayleigh, out.singleMie_);
  out.scattering_ = deltaRayleigh;
  // Multiple scattering, order by order.
  AtmosphereTable deltaMultiple = makeTable(scatterWidth, s.scatteringMu, s.scatteringR);
  AtmosphereTable density = makeTable(scatterWidth, s.scatteringMu, s.scatteringR);
  for (std::uint32_t order = 2; order <= s.scatteringOrders; ++order) {
    const Incoming incoming{look, deltaRayleigh, out.singleMie_, deltaMultiple, order == 2};
    computeScatteringDensity(shell, look, incoming, deltaIrradiance, density);
    computeIndirectIrradiance(shell, incoming, deltaIrradiance);
    for (std::size_t k = 0; k < out.irradiance_.rgb.size(); ++k) {
      out.irradiance_.rgb[k] += deltaIrradiance.rgb[k];
    }
    computeMultipleScattering(shell, look, density, deltaMultiple, out.scattering_);
  }
  return out;
}

glm::dvec3 AtmosphereTables::transmittanceToTop(double r, double mu) const noexcept {
  const Shell shell{parameters_, sizes_};
  return Lookup{shell, transmittance_}.transmittanceToTop(shell.clampRadius(r), clampCosine(mu));
}

glm::dvec3 AtmosphereTables::transmittanceToSun(double r, double muS) const noexcept {
  const Shell shell{parameters_, sizes_};
  return Lookup{shell, transmittance_}.transmittanceToSun(shell.clampRadius(r), clampCosine(muS));
}

namespace {

/// The camera moved to the top of the atmosphere along the view ray when it is above it; false
/// when the ray misses the atmosphere.
bool enterAtmosphere(const AtmosphereParameters& p, Vec3& camera, const Vec3& ray, double& r,
                     double& rmu) {
  r = glm::length(camera);
  rmu = glm::dot(camera, ray);
  const double toTop = -rmu - safeSqrt(rmu * rmu - r * r + p.topRadius * p.topRadius);
  if (toTop > 0.0) {
    camera += ray * toTop;
    r = p.topRadius;
    rmu += toTop;
  } else if (r > p.topRadius) {
    return false;
  }
  return true;
}

/// The share of a scattering table's value kept at sun cosine `muS`: the tables end at the
/// largest sun zenith angle they were computed for (their value there is clamped onto every
/// lower sun), so the light fades to none over the last 0.02 of μ_s before it, and the night
/// side's air is dark instead of lit as at that last twilight. As gpu/shaders/atmosphere.glsl.
double twilightFade(const AtmosphereParameters& p, double muS) {
  return smoothstep(p.muSMin, p.muSMin + 0.02, muS);
}

}  // namespace

AtmosphereTables::Radiance AtmosphereTables::skyRadiance(
    const glm::dvec3& cameraIn, const glm::dvec3& viewRay,
    const glm::dvec3& sunDirection) const noexcept {
  const AtmosphereParameters& p = parameters_;
  const Shell shell{p, sizes_};
  const Lookup look{shell, transmittance_};
  Vec3 camera = cameraIn;
  double r = 0.0;
  double rmu = 0.0;
  Radiance out;
  if (!enterAtmosphere(p, camera, viewRay, r, rmu)) return out;
  r = shell.clampRadius(r);
  const double mu = clampCosine(rmu / r);
  const double muS = clampCosine(glm::dot(camera, sunDirection) / r);
  const double nu = clampCosine(glm::dot(viewRay, sunDirection));
  const bool ground = shell.rayIntersectsGround(r, mu);
  out.transmittance = ground ? Vec3(0.0) : look.transmittanceToTop(r, mu);
  const Vec3 rayleigh = look.scattering(scattering_, r, mu, muS, nu, ground);
  const Vec3 mie = look.scattering(singleMie_, r, mu, muS, nu, ground);
  out.radiance =
      (rayleigh * rayleighPhase(nu) + mie * miePhase(p.miePhaseG, nu)) * twilightFade(p, muS);
  return out;
}

AtmosphereTables::Radiance AtmosphereTables::skyRadianceToPoint(
    const glm::dvec3& cameraIn, const glm::dvec3& point,
    const glm::dvec3& sunDirection) const noexcept {
  const AtmosphereParameters& p = parameters_;
  const Shell shell{p, sizes_};
  const Lookup look{shell, transmittance_};
  Vec3 camera = cameraIn;
  const Vec3 viewRay = glm::normalize(point - camera);
  double r = 0.0;
  double rmu = 0.0;
  Radiance out;
  if (!enterAtmosphere(p, camera, viewRay, r, rmu)) return out;
  r = shell.clampRadius(r);
  const double mu = clampCosine(rmu / r);
  const double muS = clampCosine(glm::dot(camera, sunDirection) / r);
  const double nu = clampCosine(glm::dot(viewRay, sunDirection));
  const double d = std::max(glm::length(point - camera), 0.0);
  const bool ground = shell.rayIntersectsGround(r, mu);
  out.transmittance = look.transmittance(r, mu, d, ground);
  const double rP = shell.clampRadius(std::sqrt(d * d + 2.0 * r * mu * d + r * r));
  const double muP = clampCosine((r * mu + d) / rP);
  const double muSP = clampCosine((r * muS + d * nu) / rP);
  const double fade = twilightFade(p, muS);
  const double fadeP = twilightFade(p, muSP);
  const Vec3 rayleigh =
      look.scattering(scattering_, r, mu, muS, nu, ground) * fade -
      out.transmittance * look.scattering(scattering_, rP, muP, muSP, nu, ground) * fadeP;
  const Vec3 mie =
      look.scattering(singleMie_, r, mu, muS, nu, ground) * fade -
      out.transmittance * look.scattering(singleMie_, rP, muP, muSP, nu, ground) * fadeP;
  out.radiance = glm::max(rayleigh, Vec3(0.0)) * rayleighPhase(nu) +
                 glm::max(mie, Vec3(0.0)) * miePhase(p.miePhaseG, nu);
  return out;
}

AtmosphereTables::Irradiance AtmosphereTables::sunAndSkyIrradiance(
    const glm::dvec3& point, const glm::dvec3& normal,
    const glm::dvec3& sunDirection) const noexcept {
  const AtmosphereParameters& p = parameters_;
  const Shell shell{p, sizes_};
  const Lookup look{shell, transmittance_};
  const double r = shell.clampRadius(glm::length(point));
  const double muS = clampCosine(glm::dot(point, sunDirection) / glm::length(point));
  Irradiance out;
  // The sky's irradiance of a tilted surface: the horizontal one times the share of the sky it
  // sees (an approximation, as in Bruneton's implementation).
  out.sky = look.irradiance(irradiance_, r, muS) *
            (1.0 + glm::dot(normal, point / glm::length(point))) * 0.5;
  out.sun = p.solarIrradiance * look.transmittanceToSun(r, muS) *
            std::max(glm::dot(normal, sunDirection), 0.0);
  return out;
}

glm::dvec3 AtmosphereTables::sunRadiance(const glm::dvec3& camera,
                                         const glm::dvec3& sunDirection) const noexcept {
  const AtmosphereParameters& p = parameters_;
  const Shell shell{p, sizes_};
  const Lookup look{shell, transmittance_};
  const double r = glm::length(camera);
  const double mu = glm::dot(camera, sunDirection) / r;
  if (shell.rayIntersectsGround(std::min(r, p.topRadius), mu)) return Vec3(0.0);
  const Vec3 t = r >= p.topRadius ? Vec3(1.0) : look.transmittanceToTop(r, mu);
  const double solidAngle = kPi * p.sunAngularRadius * p.sunAngularRadius;
  return p.solarIrradiance / solidAngle * t;
}

namespace {

constexpr char kCacheMagic[8] = {'P', 'B', 'D', 'A', 'T', 'M', '0', '1'};

/// The bytes the tables depend on: the parameters and the sizes (plain doubles and integers),
/// stored whole at the head of a cache file and compared on reading.
std::vector<std::byte> cacheKey(const AtmosphereParameters& p, const AtmosphereTableSizes& s) {
  std::vector<std::byte> key(sizeof p + sizeof s);
  std::memcpy(key.data(), &p, sizeof p);
  std::memcpy(key.data() + sizeof p, &s, sizeof s);
  return key;
}

}  // namespace

AtmosphereTables AtmosphereTables::cached(const std::filesystem::path& path,
                                          const AtmosphereParameters& parameters,
                                          const AtmosphereTableSizes& sizes, bool* computed) {
  const std::vector<std::byte> key = cacheKey(parameters, sizes);
  AtmosphereTables made;
  made.parameters_ = parameters;
  made.sizes_ = sizes;
  const std::uint32_t scatterWidth = sizes.scatteringNu * sizes.scatteringMuS;
  made.transmittance_ = makeTable(sizes.transmittanceWidth, sizes.transmittanceHeight);
  made.scattering_ = makeTable(scatterWidth, sizes.scatteringMu, sizes.scatteringR);
  made.singleMie_ = makeTable(scatterWidth, sizes.scatteringMu, sizes.scatteringR);
  made.irradiance_ = makeTable(sizes.irradianceWidth, sizes.irradianceHeight);
  const std::array<AtmosphereTable*, 4> tables = {&made.transmittance_, &made.scattering_,
                                                  &made.singleMie_, &made.irradiance_};
  {
    std::ifstream in(path, std::ios::binary);
    char magic[8] = {};
    std::vector<std::byte> stored(key.size());
    if (in.read(magic, sizeof magic) && std::memcmp(magic, kCacheMagic, sizeof magic) == 0 &&
        in.read(reinterpret_cast<char*>(stored.data()),
                static_cast<std::streamsize>(stored.size())) &&
        stored == key) {
      bool whole = true;
      for (AtmosphereTable* t : tables) {
        whole = whole && static_cast<bool>(
                             in.read(reinterpret_cast<char*>(t->rgb.data()),
                                     static_cast<std::streamsize>(t->rgb.size() * sizeof(float))));
      }
      char extra = 0;
      if (whole && !in.read(&extra, 1)) {
        if (computed) *computed = false;
        return made;
      }
    }
  }
  made = compute(parameters, sizes);
  if (computed) *computed = true;
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  const std::filesystem::path temporary = path.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(kCacheMagic, sizeof kCacheMagic);
    out.write(reinterpret_cast<const char*>(key.data()), static_cast<std::streamsize>(key.size()));
    for (const AtmosphereTable* t :
         {&made.transmittance_, &made.scattering_, &made.singleMie_, &made.irradiance_}) {
      out.write(reinterpret_cast<const char*>(t->rgb.data()),
                static_cast<std::streamsize>(t->rgb.size() * sizeof(float)));
    }
    if (!out) {
      std::filesystem::remove(temporary, ec);
      return made;
    }
  }
  std::filesystem::rename(temporary, path, ec);
  return made;
}

}  // namespace pbdam::runtime
