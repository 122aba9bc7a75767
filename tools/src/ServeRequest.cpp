// Query-string validation for `pbdam serve` (ServeRequest.h).
#include "ServeRequest.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "ExaggerationOption.h"
#include "ViewshedSpec.h"
#include "pbdam/formats/NumberList.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::tools {
namespace {

/// A short, printable echo of a client's value for error messages.
std::string shown(std::string_view value) {
  std::string out;
  for (const char c : value.substr(0, 40)) {
    out += (c >= 0x20 && c < 0x7f && c != '"' && c != '\\') ? c : '?';
  }
  if (value.size() > 40) out += "...";
  return out;
}

/// Every name in `params` is one of `allowed` and appears once.
Result<void> checkNames(const QueryParams& params,
                        std::initializer_list<std::string_view> allowed) {
  for (auto it = params.begin(); it != params.end(); it = params.upper_bound(it->first)) {
    if (std::find(allowed.begin(), allowed.end(), it->first) == allowed.end()) {
      std::string list;
      for (const std::string_view name : allowed) {
        if (!list.empty()) list += ", ";
        list += name;
      }
      return invalidArgument("unknown parameter '" + shown(it->first) + "' (expected " + list +
                             ")");
    }
    if (params.count(it->first) > 1)
      return invalidArgument("parameter '" + it->first + "' given twice");
  }
  return {};
}

std::optional<std::string> value(const QueryParams& params, const std::string& name) {
  const auto it = params.find(name);
  if (it == params.end()) return std::nullopt;
  return it->second;
}

/// A finite decimal number making up the whole value.
Result<double> number(const QueryParams& params, const std::string& name,
                      std::optional<double> fallback) {
  const std::optional<std::string> text = value(params, name);
  if (!text) {
    if (fallback) return *fallback;
    return invalidArgument("missing parameter '" + name + "'");
  }
  double v = 0.0;
  const char* begin = text->data();
  const char* end = begin + text->size();
  const auto [ptr, ec] = std::from_chars(begin, end, v);
  if (text->empty() || ec != std::errc() || ptr != end) {
    return invalidArgument("parameter '" + name + "': '" + shown(*text) + "' is not a number");
  }
  if (!std::isfinite(v)) return invalidArgument("parameter '" + name + "' must be finite");
  return v;
}

/// A decimal integer in [lo, hi] making up the whole value.
Result<std::uint32_t> integer(const QueryParams& params, const std::string& name,
                              std::uint32_t fallback, std::uint32_t lo, std::uint32_t hi) {
  const std::optional<std::string> text = value(params, name);
  if (!text) return fallback;
  std::uint64_t v = 0;
  const char* begin = text->data();
  const char* end = begin + text->size();
  const auto [ptr, ec] = std::from_chars(begin, end, v);
  if (text->empty() || ptr != end || (ec != std::errc() && ec != std::errc::result_out_of_range)) {
    return invalidArgument("parameter '" + name + "': '" + shown(*text) +
                           "' is not a whole number");
  }
  if (ec == std::errc::result_out_of_range || v < lo || v > hi) {
    return invalidArgument("parameter '" + name + "' must be in " + std::to_string(lo) + ".." +
                           std::to_string(hi));
  }
  return static_cast<std::uint32_t>(v);
}

Result<double> inRange(Result<double> v, const std::string& name, double lo, double hi) {
  if (!v) return v;
  if (*v < lo || *v > hi) {
    char text[128];
    std::snprintf(text, sizeof text, "parameter '%s' must be in [%g, %g]", name.c_str(), lo, hi);
    return invalidArgument(text);
  }
  return v;
}

}  // namespace

Result<FrameQuery> parseFrameQuery(const QueryParams& params, const Planet& planet) {
  if (auto r = checkNames(params, {"lat",    "lon",     "alt",        "heading",  "pitch",
                                   "roll",   "width",   "height",     "fov",      "tolerance",
                                   "format", "quality", "morph",      "viewshed", "time",
                                   "sun",    "ambient", "atmosphere", "exposure", "exaggeration"});
      !r) {
    return std::move(r).error();
  }
  FrameQuery q;
  CameraPose& pose = q.request.pose;
  auto lat = inRange(number(params, "lat", std::nullopt), "lat", -90.0, 90.0);
  if (!lat) return std::move(lat).error();
  auto lon = inRange(number(params, "lon", std::nullopt), "lon", -360.0, 360.0);
  if (!lon) return std::move(lon).error();
  auto alt = number(params, "alt", std::nullopt);
  if (!alt) return std::move(alt).error();
  auto heading = inRange(number(params, "heading", 0.0), "heading", -360.0, 360.0);
  if (!heading) return std::move(heading).error();
  auto pitch = inRange(number(params, "pitch", -90.0), "pitch", -90.0, 90.0);
  if (!pitch) return std::move(pitch).error();
  auto roll = inRange(number(params, "roll", 0.0), "roll", -360.0, 360.0);
  if (!roll) return std::move(roll).error();
  pose = {*lat, *lon, *alt, *heading, *pitch, *roll};
  if (auto r = validateCameraPose(pose, planet); !r) {
    return invalidArgument("parameter 'alt': " +
                           r.error().message);  // lat, lon, angles checked above
  }

  auto width = integer(params, "width", 640, 1, kMaxFrameSidePixels);
  if (!width) return std::move(width).error();
  auto height = integer(params, "height", 480, 1, kMaxFrameSidePixels);
  if (!height) return std::move(height).error();
  auto fov = number(params, "fov", 60.0);
  if (!fov) return std::move(fov).error();
  if (*fov <= 0.0 || *fov >= 179.0)
    return invalidArgument("parameter 'fov' must be in (0, 179) degrees");
  q.request.viewport = {*width, *height, *fov};
  auto tolerance = inRange(number(params, "tolerance", 3.0), "tolerance", kMinTolerancePixels,
                           kMaxTolerancePixels);
  if (!tolerance) return std::move(tolerance).error();
  q.request.tolerancePixels = *tolerance;

  if (const std::optional<std::string> morph = value(params, "morph")) {
    if (*morph != "on" && *morph != "off") {
      return invalidArgument("parameter 'morph': '" + shown(*morph) + "' is not on or off");
    }
    q.morph = *morph == "on";
  }
  if (params.count("exaggeration") != 0) {
    auto f = number(params, "exaggeration", std::nullopt);
    if (!f) return std::move(f).error();
    if (!(*f > 0.0 && *f <= kMaxExaggeration)) {
      char text[96];
      std::snprintf(text, sizeof text, "parameter 'exaggeration' must be in (0, %g]",
                    kMaxExaggeration);
      return invalidArgument(text);
    }
    q.exaggeration = *f;
  }

  std::optional<double> ambient;
  if (params.count("ambient") != 0) {
    auto a = number(params, "ambient", std::nullopt);
    if (!a) return std::move(a).error();
    ambient = *a;
  }
  std::optional<double> exposure;
  if (params.count("exposure") != 0) {
    auto e = number(params, "exposure", std::nullopt);
    if (!e) return std::move(e).error();
    exposure = *e;
  }
  const std::string time = value(params, "time").value_or("");
  const std::string sun = value(params, "sun").value_or("");
  const std::string air = value(params, "atmosphere").value_or("auto");
  for (const auto& [name, text] :
       {std::pair{"time", &time}, std::pair{"sun", &sun}, std::pair{"atmosphere", &air}}) {
    if (shown(*text) != *text) {  // parseLight echoes what it refuses: printable text only
      return invalidArgument(std::string("parameter '") + name + "': '" + shown(*text) +
                             "' is not printable text");
    }
  }
  auto light = parseLight(time, sun, 1.0, ambient, false, air, exposure);
  if (!light) return std::move(light).error();
  if (auto r = checkLightFor(*light, planet); !r) {
    return invalidArgument(std::string(light->air == Light::Air::On ? "parameter 'atmosphere': "
                                                                    : "parameter 'time': ") +
                           r.error().message);
  }
  q.request.light = *light;

  if (const std::optional<std::string> viewshed = value(params, "viewshed")) {
    auto spec = parseViewshedSpec("parameter 'viewshed'", shown(*viewshed));
    if (!spec) return std::move(spec).error();
    q.viewshed = *spec;
  }

  const std::string format = value(params, "format").value_or("png");
  if (format == "png") {
    q.encoding = FrameEncoding::Png;
  } else if (format == "jpeg" || format == "jpg") {
    q.encoding = FrameEncoding::Jpeg;
  } else {
    return invalidArgument("parameter 'format': '" + shown(format) + "' is not png or jpeg");
  }
  auto quality = integer(params, "quality", 90, 1, 100);
  if (!quality) return std::move(quality).error();
  if (q.encoding == FrameEncoding::Png && params.count("quality") != 0) {
    return invalidArgument("parameter 'quality' applies to format=jpeg only");
  }
  q.jpegQuality = static_cast<int>(*quality);
  return q;
}

namespace {

Result<gpu::GroundPoint> groundPoint(const QueryParams& params, const std::string& name) {
  const std::optional<std::string> text = value(params, name);
  if (!text)
    return invalidArgument("parameter '" + name + "' is required (LAT,LON,HEIGHT_ABOVE_GROUND_M)");
  std::vector<double> v;
  if (!parseNumberList(*text, 3, v)) {
    return invalidArgument("parameter '" + name + "': '" + shown(*text) +
                           "' is not LAT,LON,HEIGHT_ABOVE_GROUND_M");
  }
  return gpu::GroundPoint{v[0], v[1], v[2]};
}

}  // namespace

Result<LosQuery> parseLosQuery(const QueryParams& params) {
  if (auto r = checkNames(params, {"from", "to"}); !r) return std::move(r).error();
  auto from = groundPoint(params, "from");
  if (!from) return std::move(from).error();
  auto to = groundPoint(params, "to");
  if (!to) return std::move(to).error();
  return LosQuery{*from, *to};
}

Result<ViewshedQuery> parseViewshedQuery(const QueryParams& params) {
  if (auto r = checkNames(params, {"at", "radius_m", "cell_m", "format"}); !r) {
    return std::move(r).error();
  }
  ViewshedQuery q;
  auto at = groundPoint(params, "at");
  if (!at) return std::move(at).error();
  q.request.latDegrees = at->latDegrees;
  q.request.lonDegrees = at->lonDegrees;
  q.request.heightAboveGroundMeters = at->heightAboveGroundMeters;
  for (const auto& [name, field] : {std::pair{"radius_m", &q.request.radiusMeters},
                                    std::pair{"cell_m", &q.request.cellMeters}}) {
    if (params.count(name) == 0) continue;
    auto v = number(params, name, std::nullopt);
    if (!v) return std::move(v).error();
    if (!(*v > 0.0))
      return invalidArgument(std::string("parameter '") + name + "' must be > 0 metres");
    *field = *v;
  }
  const std::string format = value(params, "format").value_or("json");
  if (format == "json") {
    q.format = ViewshedFormat::Json;
  } else if (format == "tif" || format == "tiff") {
    q.format = ViewshedFormat::GeoTiff;
  } else if (format == "png") {
    q.format = ViewshedFormat::Png;
  } else {
    return invalidArgument("parameter 'format': '" + shown(format) + "' is not json, tif or png");
  }
  return q;
}

Result<HeightQuery> parseHeightQuery(const QueryParams& params) {
  if (auto r = checkNames(params, {"lat", "lon"}); !r) return std::move(r).error();
  auto lat = inRange(number(params, "lat", std::nullopt), "lat", -90.0, 90.0);
  if (!lat) return std::move(lat).error();
  auto lon = inRange(number(params, "lon", std::nullopt), "lon", -360.0, 360.0);
  if (!lon) return std::move(lon).error();
  return HeightQuery{*lat, *lon};
}

Result<void> expectNoParams(const QueryParams& params) {
  if (params.empty()) return {};
  return invalidArgument("unknown parameter '" + shown(params.begin()->first) +
                         "' (this endpoint takes none)");
}

}  // namespace pbdam::tools
