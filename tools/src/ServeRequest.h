// Query-string validation for `pbdam serve`: every parameter of GET /frame and GET /height parsed
// strictly (whole-string numbers, finite, in range; unknown or repeated names refused), so that
// a bad request becomes a 400 naming the parameter and never reaches the renderer.
// Thread-safety: pure functions.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "FrameImage.h"
#include "ServeRenderPool.h"
#include "pbdam/formats/Result.h"
#include "pbdam/gpu/GpuSightline.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/runtime/Viewshed.h"

namespace pbdam::tools {

/// Query parameters as httplib gives them (name → value, names may repeat).
using QueryParams = std::multimap<std::string, std::string>;

/// Limits of GET /frame.
inline constexpr std::uint32_t kMaxFrameSidePixels = 4096;
inline constexpr double kMinTolerancePixels = 0.5;
inline constexpr double kMaxTolerancePixels = 1000.0;

/// GET /frame, validated.
struct FrameQuery final {
  FrameRequest request;
  std::optional<bool> morph;  ///< morph=on|off; unset: the server's default
  /// exaggeration=F, in (0, 100]; unset: the server's (which is the only one it draws).
  std::optional<double> exaggeration;
  std::optional<runtime::ViewshedRequest> viewshed;  ///< viewshed=LAT,LON,H[,RADIUS_M]
  FrameEncoding encoding = FrameEncoding::Png;
  int jpegQuality = 90;
};

/// GET /height, validated.
struct HeightQuery final {
  double latDegrees = 0.0;
  double lonDegrees = 0.0;
};

/// GET /los, validated as far as the text goes (the points by gpu::sightlineOverTerrain).
struct LosQuery final {
  gpu::GroundPoint from;
  gpu::GroundPoint to;
};

/// What GET /viewshed answers with.
enum class ViewshedFormat { Json, GeoTiff, Png };

/// GET /viewshed, validated as far as the text goes (the numbers by runtime::viewshedGrid).
struct ViewshedQuery final {
  runtime::ViewshedRequest request;
  ViewshedFormat format = ViewshedFormat::Json;
};

/// Parses lat, lon, alt (required), heading (0), pitch (-90), roll (0), width (640), height
/// (480), fov (60), tolerance (3), morph (on|off; unset: the server's), format (png|jpeg),
/// quality (90, JPEG only), viewshed (LAT,LON,H[,RADIUS_M]: drape that viewshed), time (ISO 8601
/// UTC: the sun of that instant), sun (camera or AZ,EL over the view's target), ambient (0..1;
/// LightOption.h's defaults), atmosphere (auto|on|off), exposure (> 0), exaggeration ((0, 100];
/// unset: the server's). InvalidArgument
/// naming the parameter for anything missing, unknown, repeated, not a finite number, or out of
/// range (width/height 1..4096, fov (0, 179), tolerance 0.5..1000, the camera as
/// validateCameraPose on `planet`, heading/roll within ±360).
formats::Result<FrameQuery> parseFrameQuery(const QueryParams& params,
                                            const runtime::Planet& planet);

/// Parses from and to (LAT,LON,HEIGHT_ABOVE_GROUND_M), both required.
formats::Result<LosQuery> parseLosQuery(const QueryParams& params);

/// Parses at (LAT,LON,HEIGHT_ABOVE_GROUND_M, required), radius_m, cell_m and format
/// (json|tif|png, default json).
formats::Result<ViewshedQuery> parseViewshedQuery(const QueryParams& params);

/// Parses lat (±90) and lon (±360), both required; nothing else is accepted.
formats::Result<HeightQuery> parseHeightQuery(const QueryParams& params);

/// InvalidArgument naming the first parameter when `params` is not empty (endpoints that take
/// none).
formats::Result<void> expectNoParams(const QueryParams& params);

}  // namespace pbdam::tools
