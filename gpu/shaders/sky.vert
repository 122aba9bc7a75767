// The sky behind the terrain (docs/architecture.md "Light"), drawn first in a frame with the air,
// without depth test, over only the view directions that can see air: a band of directions
// around the camera's zenith, from the tangent to the top of the atmosphere (from above it; else
// the zenith itself) down to the tangent to the lowest land (12 km under the reference surface),
// kSkySegments quads around, at a great distance. From orbit it is the ring of the limb; from the
// ground, the sky above the horizon. The terrain drawn after covers what it hides; pixels outside
// the band keep the clear colour (space). sky.frag shades each from its view ray.
#version 450

#include "atmosphere.glsl"

layout(push_constant) uniform PatchPush {
  mat4 viewProjection;  // projection * viewRotation (camera-relative world -> clip)
  vec4 sunAmbient;      // xyz: unit direction towards the sun (world), w: ambient term
  uint recordIndex;
  float sunDisc;
  vec4 camera;          // xyz: the camera, planet-centred (km); w: exposure (0: no atmosphere)
} pc;

layout(location = 0) out vec3 outRay;
// The frame's sky-view frame, for sky.frag (atmosphere.glsl).
layout(location = 1) flat out vec3 outUp;
layout(location = 2) flat out vec3 outTowardsSun;
layout(location = 3) flat out vec3 outSide;
layout(location = 4) flat out vec2 outZeniths;

// Quads around the band; TerrainRenderer draws 6 vertices each (DrawRecorder.cpp kSkyVertices).
const int kSkySegments = 128;
const float kLowestLandKm = 12.0;

void main() {
  const int quad = gl_VertexIndex / 6;
  const int corner = gl_VertexIndex % 6;
  // Two triangles a quad: (0, 0) (1, 0) (0, 1), (0, 1) (1, 0) (1, 1) in (segment, edge).
  const int segment = quad + ((corner == 1 || corner == 4 || corner == 5) ? 1 : 0);
  const bool lower = corner == 2 || corner == 3 || corner == 5;
  const float r = length(pc.camera.xyz);
  const vec3 up = pc.camera.xyz / r;
  const vec3 any = abs(up.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
  const vec3 east = normalize(cross(any, up));
  const vec3 north = cross(up, east);
  const float top = r > topRadius() ? kPi - asin(topRadius() / r) : 0.0;
  const float lowest = bottomRadius() - kLowestLandKm;
  const float bottom = r > lowest ? kPi - asin(lowest / r) : kPi;
  const float zenith = lower ? bottom : top;
  const float azimuth = float(segment) * (2.0 * kPi / float(kSkySegments));
  const vec3 direction = up * cos(zenith) + (east * cos(azimuth) + north * sin(azimuth)) * sin(zenith);
  // From the atmosphere's space (the polar axis stretched onto the bottom sphere) to the world's.
  const vec3 world = normalize(vec3(direction.xy, direction.z / atmosphere.sizes.w));
  outRay = world;
  const SkyViewFrame f = skyViewFrame(pc.camera.xyz, toAtmosphereDirection(pc.sunAmbient.xyz));
  outUp = f.up;
  outTowardsSun = f.towardsSun;
  outSide = f.side;
  outZeniths = vec2(f.zenithTop, f.zenithHorizon);
  gl_Position = pc.viewProjection * vec4(world * 1.0e7, 1.0);
}
