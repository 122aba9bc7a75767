// Viewshed, pass 2 (gpu/GpuViewshed.h): one invocation per ray from the observer, at equal
// steps of azimuth. It marches the rasterised terrain outward at `stepCells`, each sample the
// bilinear blend of its four cells' terrain points, and records after every step the highest
// tangent of elevation seen so far from the eye (up over horizontal distance, in the eye's
// east-north-up frame: in the vertical plane of the ray that orders sight lines exactly).
#version 450

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Surface { vec4 p[]; } surface;
layout(std430, set = 0, binding = 1) writeonly buffer Horizons { float h[]; } horizons;

layout(push_constant) uniform March {
  uint cells;
  uint rays;
  uint steps;
  float stepCells;
  float centre;
} march;

const float kTwoPi = 6.28318530717958647692;

bool cell(int col, int row, out vec4 p) {
  if (col < 0 || row < 0 || col >= int(march.cells) || row >= int(march.cells)) return false;
  p = surface.p[uint(row) * march.cells + uint(col)];
  return p.w == 1.0;
}

void main() {
  // Rows of at most 65,535 groups (ComputeProgram.h dispatchLinear).
  const uint ray = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
  if (ray >= march.rays) return;
  const float azimuth = kTwoPi * float(ray) / float(march.rays);
  const vec2 direction = vec2(sin(azimuth), -cos(azimuth));  // rows grow southward
  float highest = -3.0e38;
  for (uint k = 1u; k <= march.steps; ++k) {
    const vec2 at = vec2(march.centre) + float(k) * march.stepCells * direction - 0.5;
    const ivec2 i0 = ivec2(floor(at));
    const vec2 f = at - vec2(i0);
    vec4 p00, p10, p01, p11;
    if (cell(i0.x, i0.y, p00) && cell(i0.x + 1, i0.y, p10) && cell(i0.x, i0.y + 1, p01) &&
        cell(i0.x + 1, i0.y + 1, p11)) {
      const vec3 p = mix(mix(p00.xyz, p10.xyz, f.x), mix(p01.xyz, p11.xyz, f.x), f.y);
      highest = max(highest, p.z / length(p.xy));
    }
    horizons.h[ray * march.steps + (k - 1u)] = highest;
  }
}
