// The mesh of a cut: its patches' vertices at their terrain points in planetocentric metres
// (double), welded across patches by their lattice point, and its triangles; no geomorph. What
// `pbdam query cut` writes and the line-of-sight test intersects. Thread-safety: pure.
#pragma once

#include <cstdint>
#include <glm/vec3.hpp>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/DatasetView.h"
#include "pbdam/runtime/Refinement.h"

namespace pbdam::runtime {

/// A welded triangle mesh in planetocentric metres.
struct CutMesh final {
  std::vector<glm::dvec3> vertices;    ///< each shared point once
  std::vector<std::uint32_t> indices;  ///< three a triangle, counter-clockwise
  int minLevel = 1 << 30;              ///< the coarsest patch level in it
  int maxLevel = -1;                   ///< the finest patch level in it
};

/// The mesh of `cut`'s patches. CorruptData naming the file and offset for a patch that does not
/// decode or whose vertex is off its node's lattice.
formats::Result<CutMesh> cutMesh(const DatasetView& view, const Cut& cut);

}  // namespace pbdam::runtime
