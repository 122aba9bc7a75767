// The sky seen along the fragment's view ray (sky.vert): the atmosphere's scattered light, the
// sun's disc through the air, black space beyond the limb, then the frame's exposure and tone
// curve (tone.glsl), or the radiance itself for a later tone map.
#version 450

#include "atmosphere.glsl"

// As patch.frag: 1 keeps the radiance for tonemap.frag, 0 tone-maps it here.
layout(constant_id = 0) const bool kRadianceOutput = false;

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;
  vec4 sunAmbient;  // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;
  float sunDisc;
  vec4 camera;      // xyz: the camera, planet-centred (km); w: exposure (0: no atmosphere)
} pc;

layout(location = 0) in vec3 inRay;

layout(location = 0) out vec4 outColor;

void main() {
  const vec3 ray = toAtmosphereDirection(inRay);
  const vec3 sun = toAtmosphereDirection(pc.sunAmbient.xyz);
  vec3 transmittance;
  vec3 radiance = skyRadiance(pc.camera.xyz, ray, sun, transmittance);
  const float sunRadius = atmosphere.solarIrradiance.w;
  if (dot(ray, sun) > cos(sunRadius)) {
    radiance += transmittance * atmosphere.solarIrradiance.xyz / (kPi * sunRadius * sunRadius);
  }
  outColor = vec4(kRadianceOutput ? radiance : toneMap(radiance, pc.camera.w), 1.0);
}
