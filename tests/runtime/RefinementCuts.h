// The refinement tests' cameras and a byte-exact text form of cuts, shared by TestRefinement.cpp
// and the child process it compares against (CutWriter.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "pbdam/formats/DemReader.h"
#include "pbdam/runtime/Camera.h"
#include "pbdam/runtime/Refinement.h"
#include "pbdam/streaming/MappedDataset.h"

namespace pbdam::test {

// A camera pose from a seeded generator: any latitude/longitude, altitude log-uniform from 10 m
// above the DEM surface up to 4 planet radii, any heading, pitch −90..−5.
inline runtime::CameraPose randomPose(std::mt19937_64& rng, const formats::HeightGrid& dem,
                                      double radius) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  runtime::CameraPose pose;
  pose.latDegrees = std::asin(2.0 * unit(rng) - 1.0) * 180.0 / 3.14159265358979323846;
  pose.lonDegrees = 360.0 * unit(rng) - 180.0;
  const double ground =
      std::max(0.0, dem.sampleBilinear(pose.latDegrees, pose.lonDegrees).value_or(0.0));
  const double above = std::exp(std::log(10.0) + unit(rng) * std::log(4.0 * radius / 10.0));
  pose.altitudeMeters = ground + above;
  pose.headingDegrees = 360.0 * unit(rng);
  pose.pitchDegrees = -5.0 - 85.0 * unit(rng);
  return pose;
}

// The cameras the tolerance and cross-process tests use: 20 seeded poses per tolerance.
struct ToleranceCamera {
  double tolerance = 0.0;
  runtime::Camera camera;
};

inline std::vector<ToleranceCamera> toleranceCameras(const runtime::DatasetView& view,
                                                     const formats::HeightGrid& dem) {
  std::vector<ToleranceCamera> cameras;
  std::mt19937_64 rng(7);
  for (const double tolerance : {1.0, 3.0, 10.0}) {
    for (int c = 0; c < 20; ++c) {
      const runtime::CameraPose pose = randomPose(rng, dem, view.planet().equatorialRadiusMeters());
      cameras.push_back({tolerance, runtime::Camera::fromPose(view.planet(), pose,
                                                              runtime::Viewport{1280, 720, 60.0})});
    }
  }
  return cameras;
}

// Every field of a cut as text, floats by their bits: equal text means byte-identical cuts.
inline std::string serializeCut(const runtime::Cut& cut) {
  std::string out;
  char line[160];
  for (const runtime::CutPatch& p : cut.patches) {
    std::uint32_t errorBits = 0;
    std::memcpy(&errorBits, &p.screenErrorPixels, sizeof errorBits);
    std::snprintf(line, sizeof line, "patch %u %u %llu level %d tile %u %llu error %08x\n",
                  unsigned{p.node.face}, unsigned{p.node.tree},
                  static_cast<unsigned long long>(p.node.heap), p.level, unsigned{p.tile.face},
                  static_cast<unsigned long long>(p.tile.heap), errorBits);
    out += line;
  }
  for (const runtime::TileKey& t : cut.tiles) {
    std::snprintf(line, sizeof line, "tile %u %llu\n", unsigned{t.face},
                  static_cast<unsigned long long>(t.heap));
    out += line;
  }
  std::snprintf(line, sizeof line, "triangles %llu vertices %llu visited %llu culled %llu\n",
                static_cast<unsigned long long>(cut.triangles),
                static_cast<unsigned long long>(cut.vertices),
                static_cast<unsigned long long>(cut.nodesVisited),
                static_cast<unsigned long long>(cut.nodesCulled));
  out += line;
  return out;
}

// The serialized cuts of all tolerance cameras on the MOLA test dataset, one "cut N" header each.
inline std::string serializeToleranceCuts(const std::filesystem::path& dir,
                                          const std::filesystem::path& demPath) {
  auto dataset = streaming::MappedDataset::open(dir);
  if (!dataset.ok()) return {};
  auto dem = formats::readDem(demPath);
  if (!dem.ok()) return {};
  std::string out;
  std::size_t index = 0;
  for (const ToleranceCamera& c : toleranceCameras((*dataset)->view(), *dem)) {
    out += "cut " + std::to_string(index++) + "\n";
    out += serializeCut(runtime::refine((*dataset)->view(), c.camera, {c.tolerance, true, -1}));
  }
  return out;
}

}  // namespace pbdam::test
