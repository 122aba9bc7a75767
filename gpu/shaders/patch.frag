// P-BDAM patch shading: the tile's texel (linear filtering; tiles carry a filtering border) lit
// by a directional sun. The shading normal averages the interpolated corner normal N(w) with the
// facet normal of the drawn triangles (screen-space derivatives of the camera-relative position),
// so that the relief shows on imagery too. Ambient + Lambert diffuse; nothing view-dependent.
#version 450

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;
  vec4 sunAmbient;  // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;
} pc;

layout(set = 1, binding = 0) uniform sampler2DArray tiles;

layout(location = 0) in vec2 inTexCoord;
layout(location = 1) flat in float inLayer;
layout(location = 2) in vec3 inNormal;
layout(location = 3) in vec3 inCameraRelative;

layout(location = 0) out vec4 outColor;

void main() {
  const vec3 smoothNormal = normalize(inNormal);
  vec3 shadingNormal = smoothNormal;
  const vec3 facet = cross(dFdx(inCameraRelative), dFdy(inCameraRelative));
  const float facetLength = length(facet);
  if (facetLength > 0.0) {
    const vec3 f = facet / facetLength;
    shadingNormal = normalize(smoothNormal + (dot(f, smoothNormal) < 0.0 ? -f : f));
  }
  const float ambient = pc.sunAmbient.w;
  const float diffuse = max(dot(shadingNormal, pc.sunAmbient.xyz), 0.0);
  const vec3 texel = texture(tiles, vec3(inTexCoord, inLayer)).rgb;
  outColor = vec4(texel * (ambient + (1.0 - ambient) * diffuse), 1.0);
}
