// `--exaggeration F`, shared by the commands that draw (render, bench, fly, serve): the terrain
// drawn with its heights times F, as Cesium and Google Earth offer (runtime::RefinementOptions::
// exaggeration). Queries (pbdam height, pbdam query) keep true heights and do not take it.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "pbdam/formats/Result.h"

namespace pbdam::tools {

/// The largest exaggeration the commands accept.
inline constexpr double kMaxExaggeration = 100.0;

/// Adds `--exaggeration` to `cmd`, read into `exaggeration` (default 1).
void addExaggerationOption(CLI::App& cmd, double& exaggeration);

/// InvalidArgument naming `name` (the option or query parameter) unless `exaggeration` is
/// finite and in (0, kMaxExaggeration].
formats::Result<void> checkExaggeration(double exaggeration,
                                        const std::string& name = "--exaggeration");

}  // namespace pbdam::tools
