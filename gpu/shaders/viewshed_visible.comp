// Viewshed, pass 3 (gpu/GpuViewshed.h): one invocation per cell of the mask. Its terrain point is
// the bilinear blend of the raster at its centre (the raster has `scale` cells a side of a mask
// cell; distances below are in raster cells). A cell in the radius is visible when the tangent
// of elevation of its terrain point is at least the horizon in front of it: the highest tangent
// the two rays on either side of its azimuth met before reaching its distance less
// `marginCells` (its own cell), interpolated between them by azimuth.
#version 450

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) readonly buffer Surface { vec4 p[]; } surface;
layout(std430, set = 0, binding = 1) readonly buffer Horizons { float h[]; } horizons;
layout(std430, set = 0, binding = 2) writeonly buffer Mask { uint m[]; } mask;

layout(push_constant) uniform Visible {
  uint cells;      // of the mask, a side
  uint fineCells;  // of the raster, a side
  uint rays;
  uint steps;
  float stepCells;
  float centre;
  float radiusCells;
  float marginCells;
  float scale;
} visible;

const float kTwoPi = 6.28318530717958647692;
const uint kHidden = 0u;
const uint kVisible = 1u;
const uint kOutside = 255u;

bool cell(int col, int row, out vec4 p) {
  if (col < 0 || row < 0 || col >= int(visible.fineCells) || row >= int(visible.fineCells)) {
    return false;
  }
  p = surface.p[uint(row) * visible.fineCells + uint(col)];
  return p.w == 1.0;
}

void main() {
  const uvec2 id = gl_GlobalInvocationID.xy;
  if (id.x >= visible.cells || id.y >= visible.cells) return;
  const uint index = id.y * visible.cells + id.x;
  const vec2 at = (vec2(id) + 0.5) * visible.scale;
  const vec2 offset = at - vec2(visible.centre);
  const float distance = length(offset);
  const ivec2 i0 = ivec2(floor(at - 0.5));
  const vec2 f = at - 0.5 - vec2(i0);
  vec4 p00, p10, p01, p11;
  if (distance > visible.radiusCells || !cell(i0.x, i0.y, p00) || !cell(i0.x + 1, i0.y, p10) ||
      !cell(i0.x, i0.y + 1, p01) || !cell(i0.x + 1, i0.y + 1, p11)) {
    mask.m[index] = kOutside;
    return;
  }
  const vec3 p = mix(mix(p00.xyz, p10.xyz, f.x), mix(p01.xyz, p11.xyz, f.x), f.y);
  const int k = int(floor((distance - visible.marginCells) / visible.stepCells));
  if (k < 1) {
    mask.m[index] = kVisible;
    return;
  }
  float azimuth = atan(offset.x, -offset.y);
  if (azimuth < 0.0) azimuth += kTwoPi;
  const float along = azimuth / kTwoPi * float(visible.rays);
  const uint r0 = min(uint(floor(along)), visible.rays - 1u);
  const uint r1 = (r0 + 1u) % visible.rays;
  const float w = clamp(along - float(r0), 0.0, 1.0);
  const uint step = min(uint(k), visible.steps) - 1u;
  const float horizon =
      mix(horizons.h[r0 * visible.steps + step], horizons.h[r1 * visible.steps + step], w);
  mask.m[index] = p.z / length(p.xy) >= horizon ? kVisible : kHidden;
}
