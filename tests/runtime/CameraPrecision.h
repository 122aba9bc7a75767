// Camera-relative precision figures on a built dataset: cameras 2 m above the highest drawn
// vertices near a point, every vertex within 1 km measured against double-precision truth for the
// shader's camera-relative positions, the paper's corner-relative ones (Fig. 5) and absolute float.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "RuntimeTestSupport.h"
#include "pbdam/runtime/Camera.h"

namespace pbdam::runtime::precision {

using formats::NodeRecord;
using formats::PatchVertex;

// The highest vertices of the leaves around (lat, lon) seen from `aboveMeters` above it, by
// distance from the planet centre.
inline std::vector<glm::dvec3> highestVertices(const DatasetView& view, test::PatchStore& store,
                                               double lat, double lon, std::size_t count,
                                               double aboveMeters, double exaggeration = 1.0) {
  const Camera above = Camera::fromPose(view.planet(), {lat, lon, aboveMeters, 0.0, -90.0, 0.0},
                                        Viewport{1280, 720, 60.0});
  RefinementOptions options{3.0, true, -1};
  options.exaggeration = exaggeration;
  const Cut cut = refine(view, above, options);
  std::vector<glm::dvec3> vertices;
  for (const CutPatch& p : cut.patches) {
    if (p.level != view.depth()) continue;
    const PatchVertexPlacement placement(view, p.node, view.node(p.node), exaggeration);
    for (const PatchVertex& v : store.mesh(p.node).vertices) {
      vertices.push_back(exactVertexPosition(placement, v, glm::dvec3(0.0)));
    }
  }
  std::sort(vertices.begin(), vertices.end(), [](const glm::dvec3& a, const glm::dvec3& b) {
    return glm::length(a) > glm::length(b);
  });
  vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
  if (vertices.size() > count) vertices.resize(count);
  return vertices;
}

struct PrecisionFigures {
  std::size_t vertices = 0;     ///< drawn vertices within 1 km of the camera
  double cameraRelative = 0.0;  ///< largest error, runtime/PatchDraw.h
  double cornerRelative = 0.0;  ///< largest error, Fig. 5 without reference points
  double absoluteFloat = 0.0;   ///< largest error, absolute float positions
};

// Cameras 2 m above each of the highest vertices near (lat, lon) (leaves seen from
// `aboveMeters`); errors of every drawn vertex within 1 km of the camera against double-precision
// truth. With `exaggeration`, of the terrain drawn with its heights times that.
inline PrecisionFigures measurePrecision(const std::filesystem::path& dir, double lat, double lon,
                                         double aboveMeters = 60e3, double exaggeration = 1.0) {
  auto dataset = streaming::MappedDataset::open(dir);
  PrecisionFigures f;
  EXPECT_TRUE(dataset.ok()) << (dataset.ok() ? "" : dataset.error().message);
  if (!dataset.ok()) return f;
  const DatasetView& view = (*dataset)->view();
  test::PatchStore store(view);
  for (const glm::dvec3& summit :
       highestVertices(view, store, lat, lon, 4, aboveMeters, exaggeration)) {
    const glm::dvec3 eye = summit + 2.0 * glm::normalize(summit);
    const GeodeticPosition g = view.planet().ecefToGeodetic(eye);
    Camera camera = Camera::fromPose(view.planet(),
                                     {g.latDegrees, g.lonDegrees, g.heightMeters, 30.0, -20.0, 0.0},
                                     Viewport{1280, 720, 60.0});
    RefinementOptions options{3.0, true, -1};
    options.exaggeration = exaggeration;
    const Cut cut = refine(view, camera, options);
    for (const CutPatch& p : cut.patches) {
      const NodeRecord record = view.node(p.node);
      const PatchDrawRecord draw = makePatchDrawRecord(
          view, PatchDrawInput{.node = p.node, .record = record}, eye, exaggeration);
      const PatchVertexPlacement placement(view, p.node, record, exaggeration);
      for (const PatchVertex& v : store.mesh(p.node).vertices) {
        // Truth: the vertex's terrain point in double. Each technique adds the decoded offset.
        const glm::dvec3 truth = exactVertexPosition(placement, v, eye);
        if (glm::length(truth) > 1000.0) continue;
        PatchVertexDisplacement h;
        if (!placement.displacement(v, h)) {
          ADD_FAILURE() << "vertex off its node's lattice";
          continue;
        }
        ++f.vertices;
        const auto err = [&](const glm::vec3& p32) { return glm::length(glm::dvec3(p32) - truth); };
        f.cameraRelative =
            std::max(f.cameraRelative, err(shaderVertexPosition(draw, v.b1, v.b2, h)));
        f.cornerRelative = std::max(f.cornerRelative,
                                    err(cornerRelativeVertexPosition(record, v.b1, v.b2, h, eye)));
        f.absoluteFloat =
            std::max(f.absoluteFloat, err(absoluteFloatVertexPosition(record, v.b1, v.b2, h, eye)));
      }
    }
  }
  std::printf(
      "%zu vertices within 1 km: camera-relative %.3g m, corner-relative (Fig. 5) %.3g m, "
      "absolute float %.3g m\n",
      f.vertices, f.cameraRelative, f.cornerRelative, f.absoluteFloat);
  return f;
}

}  // namespace pbdam::runtime::precision
