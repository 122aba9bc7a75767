// The sky-view table of a frame (atmosphere.glsl, Hillaire 2020): one invocation per texel
// computes the sky's radiance along its view direction from the frame's camera (the precomputed
// scattering's lookups), so that sky.frag reads one texel per pixel instead. Dispatched before
// the frame's passes, wherever the atmosphere is drawn.
#version 450

#define ATMOSPHERE_SET 0
#include "atmosphere.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 1, binding = 0, rgba16f) uniform writeonly image2D skyView;

layout(push_constant) uniform SkyViewPush {
  vec4 camera;  // xyz: the camera, planet-centred, in the atmosphere's space (km)
  vec4 sun;     // xyz: unit direction towards the sun, in the atmosphere's space
} pc;

void main() {
  const ivec2 size = imageSize(skyView);
  const ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
  if (texel.x >= size.x || texel.y >= size.y) return;
  const vec2 uv = (vec2(texel) + 0.5) / vec2(size);
  const SkyViewFrame f = skyViewFrame(pc.camera.xyz, pc.sun.xyz);
  const vec3 ray = normalize(skyViewRay(f, uv));
  vec3 transmittance;
  const vec3 radiance = skyRadiance(pc.camera.xyz, ray, pc.sun.xyz, transmittance);
  imageStore(skyView, texel, vec4(radiance, 1.0));
}
