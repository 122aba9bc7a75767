// Focus options (FocusOption.h).
#include "FocusOption.h"

#include <array>
#include <fstream>

#include "pbdam/formats/NumberList.h"

using namespace pbdam::formats;

namespace pbdam::tools {

void addFocusOptions(CLI::App& cmd, FocusCliOptions& o) {
  cmd.add_option("--focus", o.circle,
                 "LAT,LON,RADIUS_M: full detail (down to --focus-error-m) within the circle, the "
                 "screen-space tolerance elsewhere; the cut is closed upward so it stays "
                 "conforming (docs/architecture.md \"Selection by predicate\")");
  cmd.add_option("--focus-path", o.path,
                 "CSV of LAT,LON rows (a header row is allowed): full detail along the path, "
                 "--focus-width-m wide");
  cmd.add_option("--focus-width-m", o.widthMeters, "Width of --focus-path in metres")
      ->capture_default_str();
  cmd.add_option("--focus-error-m", o.errorMeters,
                 "Geometry error in metres inside the focus regions (0: the leaves)")
      ->capture_default_str();
}

Result<std::vector<runtime::FocusRegion>> focusRegions(const FocusCliOptions& o,
                                                       const runtime::Planet& planet) {
  const auto named = [](const std::string& option, const Error& e) {
    return makeError(ErrorCode::InvalidArgument, option + ": " + e.message);
  };
  std::vector<runtime::FocusRegion> regions;
  if (!o.circle.empty()) {
    std::vector<double> v;
    if (!parseNumberList(o.circle, 3, v)) {
      return makeError(ErrorCode::InvalidArgument,
                       "--focus '" + o.circle + "': expected LAT,LON,RADIUS_M");
    }
    auto region = runtime::focusCircle(planet, v[0], v[1], v[2], o.errorMeters);
    if (!region) return named("--focus", region.error());
    regions.push_back(std::move(*region));
  }
  if (!o.path.empty()) {
    std::ifstream in(o.path);
    if (!in)
      return makeError(ErrorCode::InvalidArgument, "--focus-path " + o.path + ": cannot read it");
    std::vector<std::array<double, 2>> points;
    std::string line;
    for (int row = 1; std::getline(in, line); ++row) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.empty()) continue;
      std::vector<double> v;
      if (!parseNumberList(line, 2, v)) {
        if (row == 1) continue;  // a header
        return makeError(
            ErrorCode::InvalidArgument,
            "--focus-path " + o.path + ":" + std::to_string(row) + ": expected LAT,LON");
      }
      points.push_back({v[0], v[1]});
    }
    auto region = runtime::focusPath(planet, points, o.widthMeters / 2.0, o.errorMeters);
    if (!region) return named("--focus-path " + o.path, region.error());
    regions.push_back(std::move(*region));
  }
  return regions;
}

}  // namespace pbdam::tools
