// P-BDAM patch shading: the tile's texel (linear filtering; tiles carry a filtering border) lit
// by a directional sun (behind the horizon of the reference surface, for the real sun, no direct
// light: the terminator). The shading normal averages the interpolated corner normal N(w) with the
// terrain's normal, so that the relief shows on imagery too. Under a real sun a simplified patch
// whose triangles are coarser than its tile's normal map reads it from the map (made by the build
// from the lattice, so distant relief keeps its shading where the drawn triangles are coarser than
// the data; runtime/NormalMap.h), blended with the facets where the two are alike in size
// (PatchDraw.cpp normalMapWeight); a leaf, which draws the lattice itself, and every patch under
// the camera light (whose frames stay those of before the normal maps, byte for byte) take the
// facet normal of the drawn triangles (screen-space derivatives of the camera-relative position).
// Ambient + Lambert diffuse; nothing view-dependent.
// Where the texture quadtree steps, the texture morph blends the parent's coarser tile (set 2,
// the page that holds it) in with the geometry's weight (docs/architecture.md "Geomorphing").
// A surface overlay (set 3; a viewshed) is blended over the texel by its alpha before lighting:
// its cells are an azimuthal equidistant grid around its centre, the fragment's place in it
// taken on the sphere of the surface's radius of curvature there.
#version 450

#include "atmosphere.glsl"

// 1: the frame keeps radiance (a floating-point target, tone-mapped by tonemap.frag after the
// last pass: frames whose radiance is read back) where the atmosphere is on; 0: the display
// colour, tone-mapped here.
layout(constant_id = 0) const bool kRadianceOutput = false;

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;
  vec4 sunAmbient;  // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;
  float sunDisc;  // sine of the sun's angular radius; 0: a light with no horizon (the camera's)
  float normalMaps;  // 1: simplified patches shaded by their tiles' normal maps under the sun
  vec4 camera;    // xyz: the camera, planet-centred (km); w: exposure (0: no atmosphere)
} pc;

layout(set = 1, binding = 0) uniform sampler2DArray tiles;
layout(set = 1, binding = 1) uniform sampler2DArray normalTiles;
layout(set = 2, binding = 0) uniform sampler2DArray morphTiles;
layout(set = 2, binding = 1) uniform sampler2DArray morphNormalTiles;
layout(set = 3, binding = 0) uniform sampler2D overlayImage;
layout(set = 3, binding = 1) uniform Overlay {
  vec4 origin;  // xyz: the overlay's centre on the reference surface, camera-relative; w: 1 drawn
  vec4 east;    // xyz: unit east there; w: the surface's radius of curvature (metres)
  vec4 north;   // xyz: unit north; w: metres per cell
  vec4 up;      // xyz: unit up; w: cells a side
} overlay;

layout(location = 0) in vec2 inTexCoord;
layout(location = 1) flat in float inLayer;
layout(location = 2) in vec3 inNormal;
layout(location = 3) in vec3 inCameraRelative;
layout(location = 4) in vec2 inMorphTexCoord;
layout(location = 5) flat in vec2 inMorphTexture;
layout(location = 6) in vec3 inInScatterLimit;
layout(location = 7) in vec3 inExtinctionPerKm;
layout(location = 8) in vec3 inSunIrradiance;
layout(location = 9) in vec3 inSkyIrradiance;
layout(location = 10) in vec3 inUp;
layout(location = 11) flat in vec4 inNormalMap;
layout(location = 12) flat in float inNormalMapShare;

layout(location = 0) out vec4 outColor;

// The terrain normal a normal-map texel holds (runtime/NormalMap.h decodeNormalTexel: companded
// components along the tangents T, B of the frame at `up`), its slope scaled by `slopeScale`.
vec3 mappedNormal(vec2 stored, vec3 up, vec3 faceU, float slopeScale) {
  const vec2 s = stored * 2.0 - 1.0;  // byte / 127.5 - 1
  vec2 c = s * abs(s);
  const float planar = dot(c, c);
  if (planar > 1.0) c *= inversesqrt(planar);
  const float z = sqrt(max(1.0 - dot(c, c), 0.0));
  const vec3 t = normalize(faceU - dot(faceU, up) * up);
  const vec3 b = cross(up, t);
  return normalize(slopeScale * (c.x * t + c.y * b) + z * up);
}

void main() {
  const vec3 smoothNormal = normalize(inNormal);
  vec3 shadingNormal = smoothNormal;
  const vec3 facet = cross(dFdx(inCameraRelative), dFdy(inCameraRelative));
  const float facetLength = length(facet);
  // Derivatives outside the branches: their conditions are per primitive, not per quad.
  const vec2 morphDx = dFdx(inMorphTexCoord);
  const vec2 morphDy = dFdy(inMorphTexCoord);
  const vec3 f = facetLength > 0.0 ? facet / facetLength : smoothNormal;
  const vec3 facetNormal = dot(f, smoothNormal) < 0.0 ? -f : f;
  if (inNormalMapShare > 0.0 && pc.sunDisc > 0.0 && pc.normalMaps > 0.0) {
    vec2 stored = texture(normalTiles, vec3(inTexCoord, inLayer)).rg;
    if (inMorphTexture.x > 0.0) {
      const vec2 coarser =
          textureGrad(morphNormalTiles, vec3(inMorphTexCoord, inMorphTexture.y), morphDx, morphDy)
              .rg;
      stored = mix(stored, coarser, inMorphTexture.x);
    }
    const vec3 mapped = mappedNormal(stored, normalize(inUp), inNormalMap.xyz, inNormalMap.w);
    shadingNormal =
        normalize(smoothNormal + normalize(mix(facetNormal, mapped, inNormalMapShare)));
  } else if (facetLength > 0.0) {
    shadingNormal = normalize(smoothNormal + facetNormal);
  }
  const float ambient = pc.sunAmbient.w;
  float diffuse = max(dot(shadingNormal, pc.sunAmbient.xyz), 0.0);
  if (pc.sunDisc > 0.0) {
    // The real sun sets: direct light is the share of its disc above the reference surface's
    // horizon (the terminator; linear in the sine of its elevation across the disc).
    diffuse *= clamp((dot(smoothNormal, pc.sunAmbient.xyz) + pc.sunDisc) / (2.0 * pc.sunDisc),
                     0.0, 1.0);
  }
  vec3 texel = texture(tiles, vec3(inTexCoord, inLayer)).rgb;
  if (inMorphTexture.x > 0.0) {
    const vec3 coarser =
        textureGrad(morphTiles, vec3(inMorphTexCoord, inMorphTexture.y), morphDx, morphDy).rgb;
    texel = mix(texel, coarser, inMorphTexture.x);
  }
  if (overlay.origin.w > 0.0) {
    const vec3 q = inCameraRelative - overlay.origin.xyz;
    const vec2 en = vec2(dot(q, overlay.east.xyz), dot(q, overlay.north.xyz));
    const float horizontal = length(en);
    const float radius = overlay.east.w;
    const float along = radius * atan(horizontal, radius + dot(q, overlay.up.xyz));
    const vec2 metres = horizontal > 0.0 ? en * (along / horizontal) : vec2(0.0);
    const vec2 uv = vec2(0.5) + vec2(metres.x, -metres.y) / (overlay.north.w * overlay.up.w);
    const vec4 cell = texture(overlayImage, uv);
    texel = mix(texel, cell.rgb, cell.a);
  }
  if (pc.camera.w > 0.0) {
    // The atmosphere: the texel as albedo under the sun and the sky through the air, seen
    // through the air between the camera and the fragment (aerial perspective; patch_vertex.glsl
    // computes the air's part per vertex), then exposed and tone-mapped.
    const vec3 albedo = srgbToLinearFast(texel);
    const float lit = max(dot(shadingNormal, pc.sunAmbient.xyz), 0.0);
    const float skyShare = (1.0 + dot(shadingNormal, smoothNormal)) * 0.5;
    vec3 radiance = albedo * (1.0 / kPi) * (inSunIrradiance * lit + inSkyIrradiance * skyShare);
    const vec3 transmittance = exp(-inExtinctionPerKm * (length(inCameraRelative) * 0.001));
    radiance = radiance * transmittance + inInScatterLimit * (vec3(1.0) - transmittance);
    // The night side's faint light: at least the albedo under the light that shows white as
    // the ambient share of white.
    radiance = max(radiance, albedo * radianceShownAs(vec3(ambient), pc.camera.w).x);
    // Kept for the tone-map pass (frames whose radiance is read back), or tone-mapped here: the
    // same colour, since nothing blends.
    outColor = vec4(kRadianceOutput ? radiance : toneMap(radiance, pc.camera.w), 1.0);
    return;
  }
  outColor = vec4(texel * (ambient + (1.0 - ambient) * diffuse), 1.0);
}
