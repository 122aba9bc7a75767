// P-BDAM patch shading: the tile's texel (linear filtering; tiles carry a filtering border) lit
// by a directional sun. The shading normal averages the interpolated corner normal N(w) with the
// facet normal of the drawn triangles (screen-space derivatives of the camera-relative position),
// so that the relief shows on imagery too. Ambient + Lambert diffuse; nothing view-dependent.
// Where the texture quadtree steps, the texture morph blends the parent's coarser tile (set 2,
// the page that holds it) in with the geometry's weight (docs/architecture.md "Geomorphing").
#version 450

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;
  vec4 sunAmbient;  // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;
} pc;

layout(set = 1, binding = 0) uniform sampler2DArray tiles;
layout(set = 2, binding = 0) uniform sampler2DArray morphTiles;

layout(location = 0) in vec2 inTexCoord;
layout(location = 1) flat in float inLayer;
layout(location = 2) in vec3 inNormal;
layout(location = 3) in vec3 inCameraRelative;
layout(location = 4) in vec2 inMorphTexCoord;
layout(location = 5) flat in vec2 inMorphTexture;

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
  vec3 texel = texture(tiles, vec3(inTexCoord, inLayer)).rgb;
  // Derivatives outside the branch: its condition is per primitive, not per quad.
  const vec2 morphDx = dFdx(inMorphTexCoord);
  const vec2 morphDy = dFdy(inMorphTexCoord);
  if (inMorphTexture.x > 0.0) {
    const vec3 coarser =
        textureGrad(morphTiles, vec3(inMorphTexCoord, inMorphTexture.y), morphDx, morphDy).rgb;
    texel = mix(texel, coarser, inMorphTexture.x);
  }
  outColor = vec4(texel * (ambient + (1.0 - ambient) * diffuse), 1.0);
}
