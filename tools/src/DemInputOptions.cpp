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

}  // namespace pbdam::tools
