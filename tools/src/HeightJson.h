// The JSON form of a rendered-surface height (`pbdam height --json` and the server's GET
// /height): one function so that both answer with the same fields. Thread-safety: pure.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "pbdam/runtime/SurfaceQuery.h"

namespace pbdam::tools {

/// {lat, lon, height_m, error_m, measured_error_m, planet, face, tree, node}.
inline nlohmann::ordered_json surfaceHeightJson(double latDegrees, double lonDegrees,
                                                const runtime::SurfaceHeight& h,
                                                const std::string& planetSpec) {
  nlohmann::ordered_json j;
  j["lat"] = latDegrees;
  j["lon"] = lonDegrees;
  j["height_m"] = h.heightMeters;
  j["error_m"] = h.leafErrorMeters;
  j["measured_error_m"] = h.leafMeasuredErrorMeters;
  j["planet"] = planetSpec;
  j["face"] = h.leaf.face;
  j["tree"] = h.leaf.tree;
  j["node"] = h.leaf.heap;
  return j;
}

}  // namespace pbdam::tools
