// Viewshed, pass 1 (gpu/GpuViewshed.h): the rendered mesh rasterised into the viewshed's grid.
// One invocation per triangle; its vertices are in grid units of the observer's azimuthal
// equidistant projection, snapped to 1/256 of a cell on the host, so that the edge functions
// in double are exact and the top-left rule gives every cell centre to exactly one triangle of
// a welded mesh (no write races, deterministic). A covered cell gets the terrain point of its
// centre — the triangle's 3D point at the centre's barycentric coordinates — in the eye's
// east-north-up frame, w = 1.
#version 450

layout(local_size_x = 64) in;

struct Vertex {
  vec4 grid;  // xy: grid units (cell c's centre at c + 0.5)
  vec4 enu;   // xyz: east, north, up metres from the eye
};

layout(std430, set = 0, binding = 0) readonly buffer Vertices { Vertex v[]; } vertices;
layout(std430, set = 0, binding = 1) readonly buffer Indices { uint i[]; } indices;
layout(std430, set = 0, binding = 2) writeonly buffer Surface { vec4 p[]; } surface;

layout(push_constant) uniform Raster {
  uint triangles;
  uint cells;
  float centre;       // grid units of the observer
  float radiusCells;  // cells farther than this from the centre are left out
} raster;

double edgeFunction(dvec2 a, dvec2 b, dvec2 p) {
  return (b.x - a.x) * (p.y - a.y) - (b.y - a.y) * (p.x - a.x);
}

// Whether a centre exactly on edge a→b (of a positively oriented triangle) belongs to it: of the
// two triangles sharing the edge, one runs it each way, so exactly one answers true.
bool ownsEdge(dvec2 a, dvec2 b) {
  const dvec2 d = b - a;
  return d.y < 0.0 || (d.y == 0.0 && d.x > 0.0);
}

bool inside(double e, bool owns) { return e > 0.0 || (e == 0.0 && owns); }

void main() {
  // Rows of at most 65,535 groups (ComputeProgram.h dispatchLinear).
  const uint t = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
  if (t >= raster.triangles) return;
  const uint ia = indices.i[3u * t];
  uint ib = indices.i[3u * t + 1u];
  uint ic = indices.i[3u * t + 2u];
  dvec2 a = dvec2(vertices.v[ia].grid.xy);
  dvec2 b = dvec2(vertices.v[ib].grid.xy);
  dvec2 c = dvec2(vertices.v[ic].grid.xy);
  double area = edgeFunction(a, b, c);
  if (area == 0.0) return;
  if (area < 0.0) {
    const uint swapIndex = ib;
    ib = ic;
    ic = swapIndex;
    const dvec2 swapPoint = b;
    b = c;
    c = swapPoint;
    area = -area;
  }
  const bool ownsAB = ownsEdge(a, b);
  const bool ownsBC = ownsEdge(b, c);
  const bool ownsCA = ownsEdge(c, a);
  const vec3 pa = vertices.v[ia].enu.xyz;
  const vec3 pb = vertices.v[ib].enu.xyz;
  const vec3 pc = vertices.v[ic].enu.xyz;
  const float lo = raster.centre - raster.radiusCells - 1.0;
  const float hi = raster.centre + raster.radiusCells + 1.0;
  const vec2 boxMin = max(vec2(min(min(a, b), c)), vec2(lo));
  const vec2 boxMax = min(vec2(max(max(a, b), c)), vec2(hi));
  const int c0 = max(0, int(ceil(boxMin.x - 0.5)));
  const int c1 = min(int(raster.cells) - 1, int(floor(boxMax.x - 0.5)));
  const int r0 = max(0, int(ceil(boxMin.y - 0.5)));
  const int r1 = min(int(raster.cells) - 1, int(floor(boxMax.y - 0.5)));
  for (int row = r0; row <= r1; ++row) {
    for (int col = c0; col <= c1; ++col) {
      const dvec2 p = dvec2(double(col) + 0.5, double(row) + 0.5);
      const double ea = edgeFunction(b, c, p);  // weight of a
      const double eb = edgeFunction(c, a, p);
      const double ec = edgeFunction(a, b, p);
      if (!inside(ea, ownsBC) || !inside(eb, ownsCA) || !inside(ec, ownsAB)) continue;
      const vec3 point = (float(ea) * pa + float(eb) * pb + float(ec) * pc) / float(area);
      surface.p[uint(row) * raster.cells + uint(col)] = vec4(point, 1.0);
    }
  }
}
