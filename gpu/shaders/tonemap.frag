// The frame's radiance (a floating-point image the terrain and the sky drew) to display colour:
// the exposure and tone curve of tone.glsl, once per pixel after the last pass.
#version 450

#include "tone.glsl"

layout(set = 0, binding = 0) uniform sampler2D radianceImage;
layout(push_constant) uniform ToneMapPush {
  float exposure;
} pc;

layout(location = 0) out vec4 outColor;

void main() {
  const vec3 radiance = texelFetch(radianceImage, ivec2(gl_FragCoord.xy), 0).rgb;
  outColor = vec4(toneMap(radiance, pc.exposure), 1.0);
}
