// `pbdam height DIR --at LAT,LON [--json]`: the height of the rendered terrain at a point, from
// the leaf patches (runtime/SurfaceQuery.h), with the stored error that bounds its distance from
// the source DEM.

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <vector>

#include "Commands.h"
#include "HeightJson.h"
#include "pbdam/formats/NumberList.h"
#include "pbdam/runtime/SurfaceQuery.h"
#include "pbdam/streaming/MappedDataset.h"
#include "pbdam/streaming/MemoryBudget.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;
using namespace pbdam::streaming;

namespace pbdam::tools {
namespace {

struct HeightCliOptions {
  std::string dir;
  std::string at;
  bool json = false;
};

int runHeight(const HeightCliOptions& o) {
  std::vector<double> latLon;
  if (!parseNumberList(o.at, 2, latLon) || std::abs(latLon[0]) > 90.0 ||
      std::abs(latLon[1]) > 360.0) {
    return reportError(
        makeError(ErrorCode::InvalidArgument,
                  "--at '" + o.at + "': expected LAT,LON in degrees (|LAT| <= 90, |LON| <= 360)"));
  }
  auto dataset = MappedDataset::open(o.dir, faceOptionsFor(cgroupMemoryLimit()));
  if (!dataset) return reportError(dataset.error());
  const DatasetView& view = (*dataset)->view();
  auto h = surfaceHeightAt(view, latLon[0], latLon[1]);
  if (!h) return reportError(h.error());
  const auto inVoid = (*dataset)->voidAt(latLon[0], latLon[1]);
  if (o.json) {
    std::cout << surfaceHeightJson(latLon[0], latLon[1], *h, view.manifest(), inVoid).dump(2)
              << "\n";
  } else {
    std::string sources;
    for (const std::string& name : heightSources(*h, view.manifest())) {
      sources += (sources.empty() ? "" : " + ") + name;
    }
    std::printf("%.3f m at %.6f, %.6f (%s; leaf error <= %.1f m; from %s)\n", h->heightMeters,
                latLon[0], latLon[1], view.manifest().planetSpec.c_str(), h->leafErrorMeters,
                sources.c_str());
    if (inVoid) {
      std::printf("in a void of %s, %s\n", view.manifest().insets[inVoid->inset].file.c_str(),
                  voidFillText(inVoid->kind));
    }
  }
  return kExitOk;
}

}  // namespace

void addHeightCommand(CLI::App& app, CommandStatus& status) {
  auto o = std::make_shared<HeightCliOptions>();
  CLI::App* cmd = app.add_subcommand(
      "height", "Height of the rendered terrain at a point (m above the reference surface)");
  cmd->add_option("DIR", o->dir, "Dataset directory")->required();
  cmd->add_option("--at", o->at, "LAT,LON in degrees (geodetic)")->required();
  cmd->add_flag("--json", o->json, "Machine-readable JSON output");
  cmd->callback([o, &status] { status.exitCode = runHeight(*o); });
}

}  // namespace pbdam::tools
