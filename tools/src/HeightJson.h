// The JSON form of a rendered-surface height (`pbdam height --json` and the server's GET
// /height): one function so that both answer with the same fields. Thread-safety: pure.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "pbdam/formats/Manifest.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::tools {

/// The sources an answer comes from: the file names of the base DEM and of the manifest's
/// insets whose bits the leaf carries (the base alone in a dataset without insets).
inline std::vector<std::string> heightSources(const runtime::SurfaceHeight& h,
                                              const formats::Manifest& manifest) {
  std::vector<std::string> names;
  if (h.leafSources == 0 || (h.leafSources & 1U) != 0) names.push_back(manifest.sourceDem);
  for (std::size_t i = 0; i < manifest.insets.size() && i < 31; ++i) {
    if ((h.leafSources >> (i + 1) & 1U) != 0) names.push_back(manifest.insets[i].file);
  }
  return names;
}

/// What the void a point lies in became, in words for the text output.
inline const char* voidFillText(formats::VoidKind kind) noexcept {
  return kind == formats::VoidKind::FilledFromRim ? "filled from its rim"
                                                  : "too large to fill: the surface below shows";
}

/// {lat, lon, height_m, error_m, measured_error_m, sources, void, planet, face, tree, node}:
/// `void` is null, or {inset, filled_from: "rim" | "surface_below"} where the point lies in a
/// void of an inset (the sample nearest it was nodata in the inset).
inline nlohmann::ordered_json surfaceHeightJson(
    double latDegrees, double lonDegrees, const runtime::SurfaceHeight& h,
    const formats::Manifest& manifest,
    const std::optional<streaming::MappedDataset::VoidAt>& inVoid = std::nullopt) {
  nlohmann::ordered_json j;
  j["lat"] = latDegrees;
  j["lon"] = lonDegrees;
  j["height_m"] = h.heightMeters;
  j["error_m"] = h.leafErrorMeters;
  j["measured_error_m"] = h.leafMeasuredErrorMeters;
  j["sources"] = heightSources(h, manifest);
  if (inVoid && inVoid->inset < manifest.insets.size()) {
    j["void"] = {{"inset", manifest.insets[inVoid->inset].file},
                 {"filled_from",
                  inVoid->kind == formats::VoidKind::FilledFromRim ? "rim" : "surface_below"}};
  } else {
    j["void"] = nullptr;
  }
  j["planet"] = manifest.planetSpec;
  j["face"] = h.leaf.face;
  j["tree"] = h.leaf.tree;
  j["node"] = h.leaf.heap;
  return j;
}

}  // namespace pbdam::tools
