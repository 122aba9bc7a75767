// `--exaggeration` (ExaggerationOption.h).
#include "ExaggerationOption.h"

#include <sstream>

namespace pbdam::tools {

void addExaggerationOption(CLI::App& cmd, double& exaggeration) {
  cmd.add_option("--exaggeration", exaggeration,
                 "Vertical exaggeration: draw heights times F, in (0, 100] (1: true heights; "
                 "queries always report true heights)")
      ->capture_default_str();
}

formats::Result<void> checkExaggeration(double exaggeration, const std::string& name) {
  if (!(exaggeration > 0.0 && exaggeration <= kMaxExaggeration)) {  // false for NaN
    std::ostringstream what;
    what << name << " " << exaggeration << " must be a number in (0, " << kMaxExaggeration << "]";
    return formats::makeError(formats::ErrorCode::InvalidArgument, what.str());
  }
  return {};
}

}  // namespace pbdam::tools
