// Test triangle: one flat colour from push constants.
#version 450

layout(push_constant) uniform TrianglePush {
  vec4 pixelPositions[3];
  vec4 colorRgba;
  vec2 viewportSizePixels;
} pc;

layout(location = 0) out vec4 outColor;

void main() {
  outColor = pc.colorRgba;
}
