// Line of sight on a triangle mesh (gpu/GpuSightline.h): one invocation per triangle intersects
// the segment from the observer (the origin: vertices are relative to it) along `direction`
// with its triangle (Möller–Trumbore) and records a hit strictly between the fractions tMin and
// tMax of the segment: their count and the nearest (positive floats order as their bits).
#version 450

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Vertices { vec4 v[]; } vertices;
layout(std430, set = 0, binding = 1) readonly buffer Indices { uint i[]; } indices;
layout(std430, set = 0, binding = 2) buffer Result {
  uint hits;
  uint nearestBits;
} result;

layout(push_constant) uniform Segment {
  vec4 direction;  // xyz: target − observer
  uint triangles;
  float tMin;
  float tMax;
} segment;

void main() {
  // Rows of at most 65,535 groups (ComputeProgram.h dispatchLinear).
  const uint t = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
  if (t >= segment.triangles) return;
  const vec3 a = vertices.v[indices.i[3u * t]].xyz;
  const vec3 b = vertices.v[indices.i[3u * t + 1u]].xyz;
  const vec3 c = vertices.v[indices.i[3u * t + 2u]].xyz;
  const vec3 d = segment.direction.xyz;
  const vec3 e1 = b - a;
  const vec3 e2 = c - a;
  const vec3 p = cross(d, e2);
  const float det = dot(e1, p);
  if (det == 0.0) return;  // the segment is parallel to the triangle
  const float inv = 1.0 / det;
  const vec3 s = -a;
  const float u = dot(s, p) * inv;
  if (u < 0.0 || u > 1.0) return;
  const vec3 q = cross(s, e1);
  const float w = dot(d, q) * inv;
  if (w < 0.0 || u + w > 1.0) return;
  const float along = dot(e2, q) * inv;
  if (along <= segment.tMin || along >= segment.tMax) return;
  atomicAdd(result.hits, 1u);
  atomicMin(result.nearestBits, floatBitsToUint(along));
}
