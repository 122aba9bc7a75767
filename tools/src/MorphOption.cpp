// `--morph` and `--morph-range` (MorphOption.h).
#include "MorphOption.h"

#include <cmath>

#include "pbdam/runtime/Refinement.h"

namespace pbdam::tools {

void addMorphOptions(CLI::App& cmd, MorphCliOptions& o, bool allowBoth) {
  cmd.add_option("--morph", o.morph,
                 allowBoth ? "Geomorphing of geometry and texture between levels: on, off or "
                             "both (one run each)"
                           : "Geomorphing of geometry and texture between levels: on or off")
      ->capture_default_str();
  cmd.add_option("--morph-range", o.range,
                 "Morph window as a fraction of the tolerance: a patch reaches its own heights "
                 "where its parent's screen error is (1 + r) times the tolerance; at most the "
                 "dataset's error margin (pbdam info)")
      ->capture_default_str();
}

formats::Result<void> checkMorphOptions(const MorphCliOptions& o, const runtime::DatasetView& view,
                                        bool allowBoth) {
  if (o.morph != "on" && o.morph != "off" && !(allowBoth && o.morph == "both")) {
    return formats::makeError(
        formats::ErrorCode::InvalidArgument,
        "--morph '" + o.morph + "': expected on, off" + (allowBoth ? " or both" : ""));
  }
  if (!std::isfinite(o.range) || o.range <= 0.0) {
    return formats::makeError(formats::ErrorCode::InvalidArgument,
                              "--morph-range must be a positive fraction of the tolerance "
                              "(--morph off turns morphing off)");
  }
  return runtime::checkMorphRange(view, o.range);
}

}  // namespace pbdam::tools
