// How the commands that read a DEM (`dem info`, `build`, `verify --dem`) take it from the command
// line: one registration of the raw-grid options, so that they are spelled and mean the same in
// each, and the note for an image read through the PDS label beside it.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "pbdam/builder/CompositeSurface.h"
#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/Result.h"

namespace pbdam::tools {

/// The raw-grid options as typed: --raw-size W,H, --raw-type T, --bounds S,W,N,E and
/// --raw-header N.
struct RawGridOptions final {
  std::string size;
  std::string type;
  std::string bounds;
  std::int64_t headerBytes = 0;

  /// Whether any of the options was given.
  bool any() const noexcept {
    return !size.empty() || !type.empty() || !bounds.empty() || headerBytes != 0;
  }
};

/// Adds --raw-size, --raw-type, --bounds and --raw-header to `command`, parsed into `options`
/// (which must outlive the parse).
void addRawGridOptions(CLI::App& command, RawGridOptions& options);

/// The layout the options describe: nullopt when none was given; an error when only some of
/// --raw-size, --raw-type and --bounds were given or one of them does not parse.
formats::Result<std::optional<formats::RawLayout>> rawLayoutOf(const RawGridOptions& options);

/// --inset FILE (repeatable), --inset-offset METRES (none, one for every inset, or one per inset
/// in the same order) and --inset-texture FILE (none, or one per inset in order, '-' for shaded
/// relief). An error names the mismatch.
formats::Result<std::vector<builder::InsetSpec>> insetSpecsOf(
    const std::vector<std::string>& paths, const std::vector<double>& offsets,
    const std::vector<std::string>& textures = {});
/// Adds --inset and --inset-offset to `command`, parsed into `paths` and `offsets`.
void addInsetOptions(CLI::App& command, std::vector<std::string>& paths,
                     std::vector<double>& offsets);
/// Adds --inset-texture (build only), parsed into `textures`.
void addInsetTextureOption(CLI::App& command, std::vector<std::string>& textures);

/// Prints a note on stderr when `demPath` names an image that will be read through the PDS
/// label beside it (pdsLabelFor), naming the label.
void noteDemLabel(const std::filesystem::path& demPath);

}  // namespace pbdam::tools
