// Test triangle: three vertices from push constants, given in framebuffer pixels (y down) plus
// a depth; converted to NDC so that a pixel position survives the viewport transform exactly.
#version 450

layout(push_constant) uniform TrianglePush {
  vec4 pixelPositions[3];   // xy: framebuffer pixels, z: depth (reversed-Z: 1 near, 0 far)
  vec4 colorRgba;
  vec2 viewportSizePixels;
} pc;

void main() {
  vec4 p = pc.pixelPositions[gl_VertexIndex];
  vec2 ndc = p.xy / pc.viewportSizePixels * 2.0 - 1.0;
  gl_Position = vec4(ndc, p.z, 1.0);
}
