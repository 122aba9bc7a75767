// `--time`, `--sun`, `--time-scale` and `--ambient`, shared by the commands users fly with
// (render, bench, fly; serve takes them as the query parameters time=, sun=, ambient=): the light
// of docs/architecture.md "Light" — a light over the camera's shoulder (the default), the real
// sun of an instant (runtime/Sun.h), or a sun at an azimuth and elevation over the view's target.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "pbdam/formats/Result.h"
#include "pbdam/gpu/TerrainRenderer.h"
#include "pbdam/runtime/Atmosphere.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::tools {

struct LightCliOptions final {
  std::string time;                 ///< ISO 8601 UTC; empty: none
  std::string sun;                  ///< camera, or AZ,EL; empty: the sun of --time, else camera
  double timeScale = 1.0;           ///< seconds of sun time per second of path time
  std::optional<double> ambient;    ///< unset: kCameraLightAmbient or kSunlightAmbient
  std::string atmosphere = "auto";  ///< auto (on under the real sun), on, off
  std::optional<double> exposure;   ///< unset: kEarthExposure scaled by the body's sunlight
  std::string normalMaps = "on";    ///< on: simplified patches shaded by their normal maps
};

/// Adds the options to `cmd`; `withTimeScale`: --time-scale too (commands that replay a path).
void addLightOptions(CLI::App& cmd, LightCliOptions& o, bool withTimeScale);

/// The ambient term of the camera light (a light with no night side).
inline constexpr float kCameraLightAmbient = 0.35f;
/// The ambient term under the real sun: the night side's faint light.
inline constexpr float kSunlightAmbient = 0.05f;
/// The atmosphere's exposure on Earth; bodies farther from the sun get more (Mars: 2.32×).
inline constexpr double kEarthExposure = 10.0;

/// What lights the frames.
struct Light final {
  enum class Kind { Camera, Ephemeris, Horizon };
  Kind kind = Kind::Camera;
  double unixSeconds = 0.0;       ///< Ephemeris: the instant of path time 0
  double timeScale = 1.0;         ///< Ephemeris: seconds of sun time per second of path time
  double azimuthDegrees = 0.0;    ///< Horizon: clockwise from north
  double elevationDegrees = 0.0;  ///< Horizon: above the target's horizon
  float ambient = kCameraLightAmbient;
  enum class Air { Auto, On, Off };
  Air air = Air::Auto;             ///< the atmosphere: auto is on under the real sun
  std::optional<double> exposure;  ///< the atmosphere's; unset: the body's default
  /// Under the sun, simplified patches shaded by their tiles' normal maps (FrameSettings).
  bool normalMaps = true;
};

/// The light of the option values, named as options ("--time") or, without `cliNames`, as query
/// parameters ("parameter 'time'"); `atmosphere` auto/on/off and `exposure` > 0: InvalidArgument
/// naming the option for a malformed time, azimuth/elevation out of range, --sun AZ,EL with
/// --time, --sun camera with --time, a time scale that is not finite, an ambient outside [0, 1].
formats::Result<Light> parseLight(std::string_view time, std::string_view sun, double timeScale,
                                  std::optional<double> ambient, bool cliNames = true,
                                  std::string_view atmosphere = "auto",
                                  std::optional<double> exposure = std::nullopt);

/// parseLight of the command-line options, and --normal-maps (on or off, else InvalidArgument).
formats::Result<Light> parseLight(const LightCliOptions& o);

/// InvalidArgument when `light` needs an ephemeris or an atmosphere `planet` has none of (the
/// Moon, custom bodies).
formats::Result<void> checkLightFor(const Light& light, const runtime::Planet& planet);

/// Whether frames under `light` over `planet` draw the atmosphere.
bool atmosphereOn(const Light& light, const runtime::Planet& planet);

/// The atmosphere's tables for `planet` when `light` draws it, else null: read from the cache
/// ($PBDAM_CACHE_DIR, else $XDG_CACHE_HOME/pbdam, else ~/.cache/pbdam) or computed once there
/// (a few seconds; said on stderr unless `quiet`).
std::shared_ptr<const runtime::AtmosphereTables> atmosphereTablesFor(const Light& light,
                                                                     const runtime::Planet& planet,
                                                                     bool quiet);

/// The geodetic point the view looks at: where the centre ray meets the sphere of the equatorial
/// radius, else the point beneath the camera. {lat, lon} in degrees.
std::pair<double, double> viewTarget(const runtime::Planet& planet, const runtime::Camera& camera);

/// The atmosphere's exposure of frames under `light` over `planet`: 0 when it is off, else
/// --exposure or the body's default (kEarthExposure scaled by the body's sunlight).
double atmosphereExposure(const Light& light, const runtime::Planet& planet);

/// What lights a run, for machine-read reports (bench's summary.json).
struct LightSummary final {
  std::string kind;  ///< "camera", "time" or "sun" (placed by azimuth and elevation)
  std::string time;  ///< time: the instant of path time 0 (ISO 8601 UTC)
  double timeScale = 1.0;
  double azimuthDegrees = 0.0;    ///< sun
  double elevationDegrees = 0.0;  ///< sun
  double ambient = 0.0;
  double exposure = 0.0;   ///< the atmosphere's; 0: no atmosphere
  bool normalMaps = true;  ///< Light::normalMaps
};
LightSummary summarizeLight(const Light& light, const runtime::Planet& planet);

/// Sets `settings`' sun and ambient for the frame at `pathSeconds`; `target`: the camera whose
/// view's target a Horizon light stands over (a path's first camera, so the light stays put).
void applyLight(const Light& light, const runtime::Planet& planet, const runtime::Camera& target,
                double pathSeconds, gpu::FrameSettings& settings);

/// One line describing the light at `pathSeconds` (e.g. "sun over 12.3°S 45.6°E at
/// 2024-03-20T06:00:00Z, Ls 123.4°"); empty for the camera light.
std::string describeLight(const Light& light, const runtime::Planet& planet,
                          const runtime::Camera& target, double pathSeconds);

}  // namespace pbdam::tools
