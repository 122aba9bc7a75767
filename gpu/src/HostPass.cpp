// The depth conventions of a host's pass (HostPass.h).
#include "pbdam/gpu/HostPass.h"

namespace pbdam::gpu {

glm::dmat4 hostProjection(const runtime::Camera& camera, DepthConvention depth) noexcept {
  glm::dmat4 p = camera.projectionDouble();
  if (depth == DepthConvention::ReversedZ) return p;
  // depth' = 1 − depth: clip z' = w − z, so row 2 becomes row 3 − row 2 (glm is column-major).
  for (int c = 0; c < 4; ++c) p[c][2] = p[c][3] - p[c][2];
  return p;
}

VkCompareOp nearerPasses(DepthConvention depth) noexcept {
  return depth == DepthConvention::ReversedZ ? VK_COMPARE_OP_GREATER_OR_EQUAL
                                             : VK_COMPARE_OP_LESS_OR_EQUAL;
}

float farDepth(DepthConvention depth) noexcept {
  return depth == DepthConvention::ReversedZ ? 0.0f : 1.0f;
}

}  // namespace pbdam::gpu
