#version 450
// The marker's vertices are relative to the terrain's camera-relative origin (float metres).
layout(push_constant) uniform Push {
  mat4 viewProjection;
} push;
layout(location = 0) in vec3 position;
void main() { gl_Position = push.viewProjection * vec4(position, 1.0); }
