// Height of the rendered terrain surface at a latitude/longitude (`pbdam height`, camera
// placement): the leaf patches around the point are decoded and the geodetic normal line through
// (lat, lon) is intersected with their triangles, each vertex placed in double exactly where the
// renderer draws it (runtime/PatchDraw.h). Leaves are what a renderer draws up close, so this is
// the height a camera would see at full detail; it differs from the source DEM by at most the
// leaf's stored error. Thread-safety: pure; decodes into its own buffers.
#pragma once

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"

namespace pbdam::runtime {

struct SurfaceHeight final {
  double heightMeters = 0.0;     ///< above the reference surface, along the geodetic normal
  NodeKey leaf;                  ///< the leaf patch whose triangle was hit
  double leafErrorMeters = 0.0;  ///< its saturated stored error
  double leafMeasuredErrorMeters = 0.0;
  /// The leaf's sources (formats::NodeRecord::sources): 0 when the dataset has no insets.
  std::uint32_t leafSources = 0;
};

/// The rendered surface height at geodetic (lat, lon) in degrees. InvalidArgument for
/// out-of-range coordinates, CorruptData if a patch fails to decode.
formats::Result<SurfaceHeight> surfaceHeightAt(const DatasetView& dataset, double latDegrees,
                                               double lonDegrees);

}  // namespace pbdam::runtime
