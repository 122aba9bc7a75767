// The raw-grid options and the PDS-label note shared by the DEM-reading commands
// (DemInputOptions.h).
#include "DemInputOptions.h"

#include <cstdio>

using namespace pbdam::formats;

namespace pbdam::tools {

void addRawGridOptions(CLI::App& command, RawGridOptions& options) {
  command.add_option("--raw-size", options.size, "Raw grid size W,H");
  command.add_option("--raw-type", options.type,
                     "Raw sample type: int16be, int16le, uint16be, float32le, ...");
  command.add_option("--bounds", options.bounds, "Raw grid area bounds S,W,N,E (degrees)");
  command.add_option("--raw-header", options.headerBytes, "Raw grid header bytes to skip")
      ->check(CLI::NonNegativeNumber);
}

Result<std::optional<RawLayout>> rawLayoutOf(const RawGridOptions& options) {
  if (!options.any()) return std::optional<RawLayout>();
  if (options.size.empty() || options.type.empty() || options.bounds.empty()) {
    return makeError(ErrorCode::InvalidArgument,
                     "a raw grid needs all of --raw-size, --raw-type and --bounds");
  }
  auto layout = parseRawType(options.type);
  if (!layout) return std::move(layout).error();
  if (auto r = parseRawSize(options.size, *layout); !r) return r.error();
  if (auto r = parseRawBounds(options.bounds, *layout); !r) return r.error();
  layout->headerBytes = options.headerBytes;
  return std::optional<RawLayout>(*layout);
}

void noteDemLabel(const std::filesystem::path& demPath) {
  if (const auto label = pdsLabelFor(demPath)) {
    std::fprintf(stderr,
                 "pbdam: note: %s has no header GDAL reads; reading it through its PDS label %s\n",
                 demPath.c_str(), label->c_str());
  }
}

Result<std::vector<builder::InsetSpec>> insetSpecsOf(const std::vector<std::string>& paths,
                                                     const std::vector<double>& offsets,
                                                     const std::vector<std::string>& textures) {
  if (!textures.empty() && textures.size() != paths.size()) {
    return makeError(ErrorCode::InvalidArgument,
                     std::to_string(textures.size()) + " --inset-texture values for " +
                         std::to_string(paths.size()) +
                         " --inset files: give one per inset in order ('-' for shaded relief)");
  }
  if (!offsets.empty() && offsets.size() != 1 && offsets.size() != paths.size()) {
    return makeError(ErrorCode::InvalidArgument,
                     std::to_string(offsets.size()) + " --inset-offset values for " +
                         std::to_string(paths.size()) +
                         " --inset files: give one for all, or one per inset in order");
  }
  if (!offsets.empty() && paths.empty()) {
    return makeError(ErrorCode::InvalidArgument, "--inset-offset needs --inset FILE");
  }
  std::vector<builder::InsetSpec> specs;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    builder::InsetSpec spec;
    spec.path = paths[i];
    if (!offsets.empty()) spec.offsetMeters = offsets[offsets.size() == 1 ? 0 : i];
    if (!textures.empty() && textures[i] != "-") spec.texturePath = textures[i];
    specs.push_back(std::move(spec));
  }
  return specs;
}

void addInsetOptions(CLI::App& command, std::vector<std::string>& paths,
                     std::vector<double>& offsets) {
  command
      .add_option("--inset", paths,
                  "A local high-resolution DEM joined to the base (repeatable; any format "
                  "`pbdam dem info` reads, or a set of tiles: a directory or a quoted glob). "
                  "Tiles that touch at one spacing are one surface; voids are filled from their "
                  "rims; the finest wins where insets overlap")
      ->type_name("FILE|DIR|GLOB");
  command
      .add_option("--inset-offset", offsets,
                  "Metres added to the insets' heights (one for all, or one per --inset): "
                  "required when an inset declares another vertical datum than the base")
      ->type_name("METRES");
}

void addInsetTextureOption(CLI::App& command, std::vector<std::string>& textures) {
  command
      .add_option("--inset-texture", textures,
                  "Imagery for each --inset, in order ('-' keeps its shaded relief): any image "
                  "`--texture` reads, or a directory or glob of georeferenced imagery tiles; "
                  "georeferenced (projected ones warped), or else taken to cover its inset's "
                  "footprint. Blended into the base across the band")
      ->type_name("FILE|DIR|GLOB");
}

}  // namespace pbdam::tools
