// P-BDAM patch vertices drawn from a draw list made on the device (draw_list.comp,
// vkCmdDrawIndexedIndirectCount): the same vertex as patch.vert, with the record index the
// draw's index in the list (gl_DrawID), since no per-draw push constant can be set there.
// On lavapipe the draw is about 1.4x slower than patch.vert's, the ratio gl_InstanceIndex gave
// (patch.vert): most likely the same per-lane gathers of a record index not known to be uniform.
// lavapipe has no subgroup operations in vertex shaders to say that it is (docs/performance.md).
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_ARB_shader_draw_parameters : require

#include "patch_vertex.glsl"

void main() { emitPatchVertex(uint(gl_DrawIDARB)); }
