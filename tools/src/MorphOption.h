// `--morph on|off` and `--morph-range r`, shared by the commands users fly with (render, bench,
// serve): the geomorph of docs/architecture.md "Geomorphing", on by default.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::tools {

struct MorphCliOptions final {
  std::string morph = "on";  ///< on, off (bench: also both)
  double range = 0.25;       ///< a fraction of the tolerance
};

/// Adds both options to `cmd`; `allowBoth`: --morph both (one run each).
void addMorphOptions(CLI::App& cmd, MorphCliOptions& o, bool allowBoth);

/// InvalidArgument naming the option: --morph not on/off(/both), or --morph-range outside
/// (0, the dataset's error margin] (runtime::checkMorphRange).
formats::Result<void> checkMorphOptions(const MorphCliOptions& o, const runtime::DatasetView& view,
                                        bool allowBoth);

/// The refinement's morph range with the morph `on` or off.
inline double morphRangeOf(const MorphCliOptions& o, bool on) noexcept {
  return on ? o.range : 0.0;
}

}  // namespace pbdam::tools
