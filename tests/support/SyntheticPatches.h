// Synthetic but realistic P-BDAM patches shared by the patch-codec tests and benchmarks: a
// regular leaf grid over smooth multi-octave terrain, and an upper-level-looking patch made by
// simplifying a fine grid with meshoptimizer. Header-only; deterministic for a given seed.
#pragma once

#include <meshoptimizer.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "pbdam/formats/PatchCodec.h"

namespace pbdam::test {

// Smooth terrain in metres over the unit square: a few octaves of sinusoids.
inline double terrainMeters(double x, double y, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> phase(0.0, 6.283185307179586);
  double h = 0.0;
  double amplitude = 400.0;
  double frequency = 1.5;
  for (int octave = 0; octave < 8; ++octave) {
    const double px = phase(rng);
    const double py = phase(rng);
    h += amplitude * std::sin(frequency * 6.283 * x + px) * std::cos(frequency * 5.65 * y + py);
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return h;
}

// A leaf patch: the regular right-triangulated grid with legs of `cells` cells (a power of two),
// (L+1)(L+2)/2 vertices and L^2 CCW triangles, heights in 1/64 m steps with DEM-like noise.
inline formats::PatchMesh gridPatch(unsigned cells, unsigned seed, double noiseMeters = 1.0) {
  std::mt19937 rng(seed * 7 + 1);
  std::uniform_real_distribution<double> noise(-noiseMeters, noiseMeters);
  formats::PatchMesh mesh;
  std::vector<unsigned> id((cells + 1) * (cells + 1));
  for (unsigned j = 0; j <= cells; ++j) {
    for (unsigned i = 0; i + j <= cells; ++i) {
      id[j * (cells + 1) + i] = static_cast<unsigned>(mesh.vertices.size());
      const double h = terrainMeters(i / double(cells), j / double(cells), seed) + noise(rng);
      mesh.vertices.push_back(
          formats::PatchVertex{static_cast<std::uint16_t>(i * 32768U / cells),
                               static_cast<std::uint16_t>(j * 32768U / cells),
                               static_cast<std::int32_t>(std::lround(h * 64.0))});
    }
  }
  auto at = [&](unsigned i, unsigned j) {
    return static_cast<std::uint16_t>(id[j * (cells + 1) + i]);
  };
  for (unsigned j = 0; j < cells; ++j) {
    for (unsigned i = 0; i + j < cells; ++i) {
      mesh.indices.insert(mesh.indices.end(), {at(i, j), at(i + 1, j), at(i, j + 1)});
      if (i + j + 1 < cells) {
        mesh.indices.insert(mesh.indices.end(), {at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
  }
  return mesh;
}

// An upper-level-looking patch: a fine grid simplified by meshopt_simplify (quadric error) to
// about `triangles` triangles, then optimised for rendering (~500 vertices for 1000 triangles).
inline formats::PatchMesh simplifiedPatch(unsigned fineCells, std::size_t triangles,
                                          unsigned seed) {
  const formats::PatchMesh fine = gridPatch(fineCells, seed, 0.5);
  std::vector<float> positions(fine.vertices.size() * 3);
  const double cellMeters = 400.0;
  for (std::size_t i = 0; i < fine.vertices.size(); ++i) {
    positions[3 * i] = static_cast<float>(fine.vertices[i].b1 / 32768.0 * fineCells * cellMeters);
    positions[3 * i + 1] =
        static_cast<float>(fine.vertices[i].b2 / 32768.0 * fineCells * cellMeters);
    positions[3 * i + 2] = static_cast<float>(fine.vertices[i].heightSteps / 64.0);
  }
  std::vector<std::uint16_t> simplified(fine.indices.size());
  const std::size_t count = meshopt_simplify(
      simplified.data(), fine.indices.data(), fine.indices.size(), positions.data(),
      fine.vertices.size(), 3 * sizeof(float), triangles * 3, 1.0f, 0, nullptr);
  formats::PatchMesh mesh;
  mesh.vertices = fine.vertices;
  mesh.indices.assign(simplified.begin(), simplified.begin() + static_cast<std::ptrdiff_t>(count));
  formats::optimizePatchForRendering(mesh);
  return mesh;
}

}  // namespace pbdam::test
