// P-BDAM patch vertices (docs/architecture.md "Refinement and drawing"): one indexed draw per patch, its PatchDrawRecord picked by
// the push constant recordIndex, set before each draw. (Not gl_InstanceIndex with firstInstance:
// lavapipe cannot prove an instance index uniform, so every record load became an 8-lane gather;
// a push constant is uniform and made the vertex stage about twice as fast — docs/decisions.md.)
// Vertex attributes: the barycentrics b1, b2 (R16G16_UINT), the displacement h in metres along
// the interpolated normal and that of the vertex's morph target (R32G32_SFLOAT) and the sideways
// offset o that takes the displaced point
// to the vertex's terrain point (R32G32B32_SFLOAT), both computed in double at decode
// (runtime/PatchDraw.h). Texture coordinates come from the vertex's position
// (patch_texcoord.glsl), not from w; the normal is still interpolated in w.
#version 450
#extension GL_GOOGLE_include_directive : require

#include "patch_vertex.glsl"

void main() { emitPatchVertex(pc.recordIndex); }
