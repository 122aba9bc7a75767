// The light options (LightOption.h).
#include "LightOption.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <glm/geometric.hpp>
#include <vector>

#include "pbdam/formats/NumberList.h"
#include "pbdam/runtime/Sun.h"

namespace pbdam::tools {

using formats::ErrorCode;
using formats::makeError;
using formats::Result;

namespace {

/// The table sizes of rendering: a few seconds to compute on two cores, then cached.
runtime::AtmosphereTableSizes renderTableSizes() {
  runtime::AtmosphereTableSizes s;
  s.scatteringR = 16;
  s.scatteringMu = 64;
  s.scatteringMuS = 16;
  s.scatteringNu = 8;
  return s;
}

}  // namespace

void addLightOptions(CLI::App& cmd, LightCliOptions& o, bool withTimeScale) {
  cmd.add_option("--time", o.time,
                 "Light the planet by the sun of this UTC instant (ISO 8601, e.g. "
                 "2024-03-20T06:00:00Z): Earth (Meeus) and Mars (Mars24) only; a path's frames "
                 "at this time plus --time-scale times their path time");
  cmd.add_option("--sun", o.sun,
                 "camera: a light over the camera's shoulder (the default without --time); AZ,EL: "
                 "a sun at this azimuth (clockwise from north) and elevation in degrees over the "
                 "view's target (a path's first)");
  if (withTimeScale) {
    cmd.add_option("--time-scale", o.timeScale,
                   "Seconds of sun time per second of path time (with --time; e.g. 600 flies a "
                   "sunrise in seconds)")
        ->capture_default_str();
  }
  cmd.add_option("--ambient", o.ambient,
                 "Share of a texel's colour the unlit side keeps, 0..1 (default 0.35 under the "
                 "camera light, 0.05 under the sun: the night side)");
  cmd.add_option("--atmosphere", o.atmosphere,
                 "auto: the sky, the limb and the aerial perspective of Earth's or Mars's "
                 "atmosphere under the sun of --time or --sun AZ,EL; on: also under the camera "
                 "light; off: none")
      ->capture_default_str();
  cmd.add_option("--exposure", o.exposure,
                 "The atmosphere's exposure: radiance times this through a 1 - e^-x curve "
                 "(default 10 on Earth, 23 on Mars)");
  cmd.add_option("--normal-maps", o.normalMaps,
                 "on: under the sun, patches coarser than the data are shaded by the normal maps "
                 "the build made from it (distant relief keeps its shading); off: by their drawn "
                 "triangles, as leaves and every patch under the camera light are")
      ->capture_default_str();
}

Result<Light> parseLight(std::string_view time, std::string_view sun, double timeScale,
                         std::optional<double> ambient, bool cliNames, std::string_view atmosphere,
                         std::optional<double> exposure) {
  const std::string timeName = cliNames ? "--time" : "parameter 'time'";
  const std::string sunName = cliNames ? "--sun" : "parameter 'sun'";
  const std::string ambientName = cliNames ? "--ambient" : "parameter 'ambient'";
  Light light;
  if (!time.empty()) {
    if (!sun.empty()) {
      return makeError(ErrorCode::InvalidArgument,
                       sunName + " ('" + std::string(sun) + "') and " + timeName +
                           ": the time places the sun; give one of them");
    }
    auto t = runtime::parseUtcTime(time);
    if (!t) return makeError(ErrorCode::InvalidArgument, timeName + ": " + t.error().message);
    if (!std::isfinite(timeScale)) {
      return makeError(ErrorCode::InvalidArgument, "--time-scale must be a finite number");
    }
    light.kind = Light::Kind::Ephemeris;
    light.unixSeconds = *t;
    light.timeScale = timeScale;
  } else if (!sun.empty() && sun != "camera") {
    std::vector<double> azEl;
    if (!formats::parseNumberList(sun, 2, azEl) || azEl[1] < -90.0 || azEl[1] > 90.0 ||
        azEl[0] < -360.0 || azEl[0] > 360.0) {
      return makeError(ErrorCode::InvalidArgument,
                       sunName + " ('" + std::string(sun) +
                           "'): expected camera or AZ,EL (azimuth −360..360°, elevation "
                           "−90..90°)");
    }
    light.kind = Light::Kind::Horizon;
    light.azimuthDegrees = azEl[0];
    light.elevationDegrees = azEl[1];
  }
  light.ambient = light.kind == Light::Kind::Camera ? kCameraLightAmbient : kSunlightAmbient;
  if (ambient) {
    if (!std::isfinite(*ambient) || *ambient < 0.0 || *ambient > 1.0) {
      return makeError(ErrorCode::InvalidArgument, ambientName + " must be in 0..1");
    }
    light.ambient = static_cast<float>(*ambient);
  }
  const std::string airName = cliNames ? "--atmosphere" : "parameter 'atmosphere'";
  if (atmosphere == "auto") {
    light.air = Light::Air::Auto;
  } else if (atmosphere == "on") {
    light.air = Light::Air::On;
  } else if (atmosphere == "off") {
    light.air = Light::Air::Off;
  } else {
    return makeError(ErrorCode::InvalidArgument,
                     airName + " ('" + std::string(atmosphere) + "'): expected auto, on or off");
  }
  if (exposure) {
    if (!std::isfinite(*exposure) || *exposure <= 0.0 || *exposure > 1e6) {
      return makeError(ErrorCode::InvalidArgument,
                       std::string(cliNames ? "--exposure" : "parameter 'exposure'") +
                           " must be a number in (0, 1e6]");
    }
    light.exposure = *exposure;
  }
  return light;
}

Result<Light> parseLight(const LightCliOptions& o) {
  if (o.normalMaps != "on" && o.normalMaps != "off") {
    return makeError(ErrorCode::InvalidArgument,
                     "--normal-maps '" + o.normalMaps + "': expected on or off");
  }
  auto light = parseLight(o.time, o.sun, o.timeScale, o.ambient, true, o.atmosphere, o.exposure);
  if (light) light->normalMaps = o.normalMaps == "on";
  return light;
}

Result<void> checkLightFor(const Light& light, const runtime::Planet& planet) {
  if (light.air == Light::Air::On && !runtime::AtmosphereParameters::of(planet)) {
    return makeError(ErrorCode::InvalidArgument,
                     "no atmosphere for planet '" + planet.name() +
                         "' (Earth and Mars have one): --atmosphere on needs one");
  }
  if (light.kind != Light::Kind::Ephemeris) return {};
  if (auto p = runtime::subsolarPoint(planet, light.unixSeconds); !p) return p.error();
  return {};
}

bool atmosphereOn(const Light& light, const runtime::Planet& planet) {
  if (light.air == Light::Air::Off || !runtime::AtmosphereParameters::of(planet)) return false;
  return light.air == Light::Air::On || light.kind != Light::Kind::Camera;
}

std::shared_ptr<const runtime::AtmosphereTables> atmosphereTablesFor(const Light& light,
                                                                     const runtime::Planet& planet,
                                                                     bool quiet) {
  if (!atmosphereOn(light, planet)) return nullptr;
  std::filesystem::path dir;
  if (const char* own = std::getenv("PBDAM_CACHE_DIR"); own && *own) {
    dir = own;
  } else if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
    dir = std::filesystem::path(xdg) / "pbdam";
  } else if (const char* home = std::getenv("HOME"); home && *home) {
    dir = std::filesystem::path(home) / ".cache" / "pbdam";
  } else {
    dir = std::filesystem::temp_directory_path() / "pbdam";
  }
  const runtime::AtmosphereParameters parameters = *runtime::AtmosphereParameters::of(planet);
  const runtime::AtmosphereTableSizes sizes = renderTableSizes();
  const auto start = std::chrono::steady_clock::now();
  bool computed = false;
  const std::filesystem::path file = dir / ("atmosphere-" + planet.name() + ".bin");
  auto tables = std::make_shared<const runtime::AtmosphereTables>(
      runtime::AtmosphereTables::cached(file, parameters, sizes, &computed));
  if (computed && !quiet) {
    std::fprintf(stderr, "pbdam: atmosphere tables computed in %.1f s (kept in %s)\n",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                 file.string().c_str());
  }
  return tables;
}

std::pair<double, double> viewTarget(const runtime::Planet& planet, const runtime::Camera& camera) {
  const glm::dvec3 origin = camera.position();
  const glm::dvec3 ray = camera.forward();
  const double radius = planet.equatorialRadiusMeters();
  const double b = glm::dot(origin, ray);
  const double c = glm::dot(origin, origin) - radius * radius;
  glm::dvec3 point = origin;
  if (const double disc = b * b - c; disc >= 0.0 && -b - std::sqrt(disc) > 0.0) {
    point = origin + (-b - std::sqrt(disc)) * ray;
  }
  const runtime::GeodeticPosition g = planet.ecefToGeodetic(point);
  return {g.latDegrees, g.lonDegrees};
}

namespace {

/// The body's mean distance from the sun (AU), for the disc of a sun placed by hand.
double meanDistanceAu(const runtime::Planet& planet) {
  return runtime::solarBodyOf(planet) == runtime::SolarBody::Mars ? 1.5237 : 1.0;
}

}  // namespace

double atmosphereExposure(const Light& light, const runtime::Planet& planet) {
  if (!atmosphereOn(light, planet)) return 0.0;
  const double sunlight = runtime::AtmosphereParameters::of(planet)->solarIrradiance.y /
                          runtime::AtmosphereParameters::earth().solarIrradiance.y;
  return light.exposure.value_or(kEarthExposure / sunlight);
}

LightSummary summarizeLight(const Light& light, const runtime::Planet& planet) {
  LightSummary s;
  switch (light.kind) {
    case Light::Kind::Camera:
      s.kind = "camera";
      break;
    case Light::Kind::Ephemeris:
      s.kind = "time";
      s.time = runtime::formatUtcTime(light.unixSeconds);
      s.timeScale = light.timeScale;
      break;
    case Light::Kind::Horizon:
      s.kind = "sun";
      s.azimuthDegrees = light.azimuthDegrees;
      s.elevationDegrees = light.elevationDegrees;
      break;
  }
  s.ambient = static_cast<double>(light.ambient);
  s.exposure = atmosphereExposure(light, planet);
  s.normalMaps = light.normalMaps;
  return s;
}

void applyLight(const Light& light, const runtime::Planet& planet, const runtime::Camera& target,
                double pathSeconds, gpu::FrameSettings& settings) {
  settings.ambient = light.ambient;
  settings.normalMaps = light.normalMaps;
  settings.atmosphereExposure = static_cast<float>(atmosphereExposure(light, planet));
  switch (light.kind) {
    case Light::Kind::Camera:
      settings.sunDirectionEcef.reset();
      settings.sunAngularRadiusRadians = 0.0f;
      return;
    case Light::Kind::Ephemeris: {
      auto sun = runtime::subsolarPoint(planet, light.unixSeconds + light.timeScale * pathSeconds);
      if (!sun) return;  // checkLightFor refused it before
      settings.sunDirectionEcef = runtime::sunDirectionEcef(planet, *sun);
      settings.sunAngularRadiusRadians =
          static_cast<float>(runtime::sunAngularRadiusRadians(sun->distanceAu));
      return;
    }
    case Light::Kind::Horizon: {
      const auto [lat, lon] = viewTarget(planet, target);
      settings.sunDirectionEcef = runtime::sunDirectionFromHorizon(
          planet, lat, lon, light.azimuthDegrees, light.elevationDegrees);
      settings.sunAngularRadiusRadians =
          static_cast<float>(runtime::sunAngularRadiusRadians(meanDistanceAu(planet)));
      return;
    }
  }
}

std::string describeLight(const Light& light, const runtime::Planet& planet,
                          const runtime::Camera& target, double pathSeconds) {
  char text[160];
  switch (light.kind) {
    case Light::Kind::Camera:
      return {};
    case Light::Kind::Ephemeris: {
      const double t = light.unixSeconds + light.timeScale * pathSeconds;
      auto sun = runtime::subsolarPoint(planet, t);
      if (!sun) return {};
      std::snprintf(text, sizeof text, "sun over %.2f°%c %.2f°%c at %s", std::abs(sun->latDegrees),
                    sun->latDegrees < 0.0 ? 'S' : 'N', std::abs(sun->lonDegrees),
                    sun->lonDegrees < 0.0 ? 'W' : 'E', runtime::formatUtcTime(t).c_str());
      std::string line = text;
      if (runtime::solarBodyOf(planet) == runtime::SolarBody::Mars) {
        std::snprintf(text, sizeof text, " (Ls %.1f°)",
                      runtime::marsSolarTime(t).solarLongitudeDegrees);
        line += text;
      }
      return line;
    }
    case Light::Kind::Horizon: {
      const auto [lat, lon] = viewTarget(planet, target);
      std::snprintf(text, sizeof text, "sun at azimuth %.1f°, elevation %.1f° over %.3f,%.3f",
                    light.azimuthDegrees, light.elevationDegrees, lat, lon);
      return text;
    }
  }
  return {};
}

}  // namespace pbdam::tools
