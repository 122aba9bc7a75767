// `--focus LAT,LON,RADIUS_M`, `--focus-path FILE.csv --focus-width-m W` and `--focus-error-m E`,
// shared by `render` and `query cut`: focus regions of a cut selected by predicate
// (runtime/Selection.h).
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Planet.h"
#include "pbdam/runtime/Selection.h"

namespace pbdam::tools {

struct FocusCliOptions final {
  std::string circle;           ///< LAT,LON,RADIUS_M
  std::string path;             ///< CSV of lat,lon rows (a header row is allowed)
  double widthMeters = 1000.0;  ///< the path's full width
  double errorMeters = 0.0;     ///< geometry error inside; 0: the leaves
};

void addFocusOptions(CLI::App& cmd, FocusCliOptions& o);

/// The regions the options describe (none without --focus or --focus-path); InvalidArgument
/// naming the option for a malformed or out-of-range value, an unreadable or empty path file.
formats::Result<std::vector<runtime::FocusRegion>> focusRegions(const FocusCliOptions& o,
                                                                const runtime::Planet& planet);

}  // namespace pbdam::tools
