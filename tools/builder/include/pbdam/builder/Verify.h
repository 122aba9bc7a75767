// `pbdam verify`: checks a dataset against every invariant P-BDAM relies on (docs/builder.md):
// checksums and decodability of every section, header/manifest agreement, error nesting over
// the diamond DAG across faces, diamond partners sharing error and sphere, sphere containment,
// patches covering their triangles without flips, identical vertex sets (and heights) on
// every edge two patches can share in a conforming cut, and — given the source DEM — stored
// error ≥ the patch's deviation from every DEM sample it covers. Thread-safety: independent
// calls may run concurrently.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/Result.h"

namespace pbdam::builder {

struct VerifyOptions final {
  std::filesystem::path datasetDir;
  std::filesystem::path demPath;  ///< empty: skip the error-against-DEM check
  std::optional<formats::RawLayout> rawLayout;
  /// The insets the dataset was built with: errors are then checked against the composite's
  /// samples (CompositeSurface.h), as the builder measured them.
  std::vector<InsetSpec> insets;
  std::size_t maxViolations = 20;  ///< stop collecting after this many
  std::function<void(std::string_view stage, double fraction)> progress;
};

struct VerifyReport final {
  std::vector<std::string> violations;  ///< the first maxViolations, each naming where
  std::uint64_t violationCount = 0;
  std::uint64_t nodesChecked = 0;
  std::uint64_t patchesDecoded = 0;
  std::uint64_t morphTargetsChecked = 0;  ///< patches whose targets were recomputed and matched
  std::uint64_t tilesDecoded = 0;
  std::uint64_t edgesCompared = 0;
  std::uint64_t demSamplesChecked = 0;
  double worstErrorRatio = 0.0;  ///< max over patches of (DEM deviation / stored)
  bool ok() const noexcept { return violationCount == 0; }
};

/// Runs every check. Returns an error only when verification cannot start (no manifest, DEM
/// unreadable); a damaged dataset gives a report with violations.
formats::Result<VerifyReport> verifyDataset(const VerifyOptions& options);

}  // namespace pbdam::builder
