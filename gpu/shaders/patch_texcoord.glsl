// A patch vertex's texture coordinates in its tile, from where the vertex is (runtime/PatchDraw.h;
// mirrored by pbdam::shaderTexCoord). Included after patch_position.glsl (the record) by
// patch.vert and by the GPU tests' capture shader.
//
// The builder puts a vertex of face coordinates (u, v) at T = surface(d) + H n(d), d the
// tangent-adjusted direction of (u, v) (CubeMap.h). This inverts that on the record's own face
// (never the face of the major axis: a vertex on a face edge belongs to its patch's face), with
// two fixed-point steps on an ellipsoid, and returns the tile's texture coordinate
// tc = 0.5 + k (u - uc, v - vc), affine in (u, v), (uc, vc) the tile's centre. Everything is
// relative to the tile centre's surface point Q: the plane coordinates p = tan(pi/4 (2u - 1)) are
// formed as differences p - pc from the vertex's offset T - Q, and
// u - uc = (2/pi)(atan p - atan pc) = (2/pi) atan((p - pc) / (1 + p pc)), so the rounding error
// scales with the tile, not with the planet's radius (no absolute float position is rounded).

// Face frames (CubeMap.h): the outward axis n and the axes U, V in which u and v grow.
const vec3 kFaceNormal[6] = vec3[6](vec3(1, 0, 0), vec3(0, 1, 0), vec3(-1, 0, 0), vec3(0, -1, 0),
                                    vec3(0, 0, 1), vec3(0, 0, -1));
const vec3 kFaceU[6] = vec3[6](vec3(0, 1, 0), vec3(-1, 0, 0), vec3(0, -1, 0), vec3(1, 0, 0),
                               vec3(0, 1, 0), vec3(0, 1, 0));
const vec3 kFaceV[6] = vec3[6](vec3(0, 0, 1), vec3(0, 0, 1), vec3(0, 0, 1), vec3(0, 0, 1),
                               vec3(-1, 0, 0), vec3(1, 0, 0));

// The tile texture coordinates of the vertex at `cameraRelative` (its position minus the camera)
// of the patch drawn with record `r`, and the reference surface's unit normal below it (`up`: the
// frame its tile's normal map is stored in, runtime/NormalMap.h).
vec2 patchVertexTexCoordAndUp(uint r, vec3 cameraRelative, out vec3 up) {
  const vec4 center = draws.records[r].texCenter;
  const vec4 plane = draws.records[r].texPlane;
  const int face = int(plane.w);
  const vec3 en = kFaceNormal[face];
  const vec3 eu = kFaceU[face];
  const vec3 ev = kFaceV[face];
  const vec2 plane0 = plane.xy;
  const float qn = plane.z;
  // T - Q, and T itself (absolute, only to find the ellipsoid normal and the height).
  const vec3 delta = cameraRelative - center.xyz;
  const vec3 t = qn * ((en + plane0.x * eu) + plane0.y * ev) + delta;
  // One fixed-point step: S0 = k T on the ellipsoid, n0 its normal, H ~ (T - S0) . n0,
  // D = T - H n0 (on a sphere D is T scaled: the direction is T's).
  const float a = draws.records[r].corner[1].w;
  const float b = draws.records[r].corner[2].w;
  const vec3 e = vec3(t.xy / a, t.z / b);
  const float k = inversesqrt(dot(e, e));
  const vec3 n0 = normalize(vec3(e.xy / a, e.z / b));
  const float h0 = (1.0 - k) * dot(t, n0);
  // A second step from D0 = T - h0 n0: S1 = k1 D0 on the ellipsoid, n1 its normal,
  // H = (T - S1) . n1 = (1 - k1) T . n1 + k1 h0 n0 . n1 (no cancellation). One step leaves up to
  // 0.8 m at 21 km height on Mars' ellipsoid, two leave millimetres.
  const vec3 d0 = t - h0 * n0;
  const vec3 e1 = vec3(d0.xy / a, d0.z / b);
  const float k1 = inversesqrt(dot(e1, e1));
  const vec3 n1 = normalize(vec3(e1.xy / a, e1.z / b));
  const float h = (1.0 - k1) * dot(t, n1) + k1 * h0 * dot(n0, n1);
  const vec3 dq = delta - h * n1;  // D - Q
  // D's plane coordinates relative to Q's, then u - uc, v - vc.
  const float dn = dot(dq, en);
  const vec2 dPlane = (vec2(dot(dq, eu), dot(dq, ev)) - plane0 * dn) / (qn + dn);
  const vec2 dUv = (2.0 / 3.14159265358979) * atan(dPlane / (1.0 + plane0 * (plane0 + dPlane)));
  up = n1;
  return 0.5 + center.w * dUv;
}

vec2 patchVertexTexCoord(uint r, vec3 cameraRelative) {
  vec3 up;
  return patchVertexTexCoordAndUp(r, cameraRelative, up);
}
