// The sky seen along the fragment's view ray (sky.vert): the atmosphere's scattered light (from
// the frame's sky-view table), the sun's disc through the air, black space beyond the limb, then the frame's exposure and tone
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

// The frame's sky-view table (sky_view.comp; atmosphere.glsl).
layout(set = 4, binding = 5) uniform sampler2D skyViewTable;

layout(location = 0) in vec3 inRay;
// The frame's sky-view frame (the same for every pixel: sky.vert computes it).
layout(location = 1) flat in vec3 inUp;
layout(location = 2) flat in vec3 inTowardsSun;
layout(location = 3) flat in vec3 inSide;
layout(location = 4) flat in vec2 inZeniths;  // x: zenithTop, y: zenithHorizon

layout(location = 0) out vec4 outColor;

void main() {
  const vec3 ray = toAtmosphereDirection(inRay);
  const vec3 sun = toAtmosphereDirection(pc.sunAmbient.xyz);
  const SkyViewFrame f = SkyViewFrame(inUp, inTowardsSun, inSide, inZeniths.x, inZeniths.y);
  // Beyond the tangent to the top of the atmosphere (from above it) the ray meets no air.
  const float zenith = acos(clamp(dot(ray, f.up), -1.0, 1.0));
  vec3 radiance = zenith < f.zenithTop ? vec3(0.0)
                                       : texture(skyViewTable, skyViewUv(f, ray, zenith)).rgb;
  const float sunRadius = atmosphere.solarIrradiance.w;
  if (dot(ray, sun) > cos(sunRadius)) {
    // The sun's disc through the air (its pixels alone look the transmittance up).
    vec3 transmittance;
    skyRadiance(pc.camera.xyz, ray, sun, transmittance);
    radiance += transmittance * atmosphere.solarIrradiance.xyz / (kPi * sunRadius * sunRadius);
  }
  outColor = vec4(kRadianceOutput ? radiance : toneMap(radiance, pc.camera.w), 1.0);
}
