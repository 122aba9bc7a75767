// A parent patch's sample error bounded through its children's patches, without reading the
// samples ([P-BDAM 2003] §5: each level from the level below; docs/builder.md "Errors").
// Private to the builder.
#pragma once

#include <span>
#include <vector>

#include "pbdam/builder/LatticeTiles.h"
#include "pbdam/builder/PatchBuilder.h"

namespace pbdam::builder {

/// For every triangle T of `patch` (a parent's half on the face of `heights`), an upper bound of
/// |patch − sample| over every sample (lattice or source) inside or on T, from the children's
/// patches that tile T's half and their per-triangle bounds (WorkPatch::sampleErrorMeters).
/// A sample x of T lies in a child triangle t that overlaps T; on t the child surface S and T's
/// plane P are both linear, so |P(x) − S(x)| is at most the largest |P − S| at t's corners (P
/// extended beyond T where t reaches out of it), and |S(x) − sample| at most t's bound:
///   bound(T) = max over child triangles t overlapping T of (max over t's corners |P − h| + e(t)).
/// Exact integer overlap tests (interiors that meet); +infinity for a triangle no child triangle
/// overlaps. Empty when a child carries no per-triangle bounds.
std::vector<double> childBoundedSampleErrors(const FaceHeights& heights, const WorkPatch& patch,
                                             std::span<const WorkPatch* const> children);

}  // namespace pbdam::builder
