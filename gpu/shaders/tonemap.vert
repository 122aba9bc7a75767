// The tone map's triangle over the viewport (tonemap.frag reads its pixel by gl_FragCoord).
#version 450

void main() {
  const vec2 corner = vec2(float((gl_VertexIndex << 1) & 2), float(gl_VertexIndex & 2));
  gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
