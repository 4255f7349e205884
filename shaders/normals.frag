#version 330 core
// Raycast normals as colours: 0.5 + 0.5 * (n.x, -n.y, -n.z). Mirrors shade_normal() in
// src/render/composite.cpp.
in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_depth;    // R32F, metres, <= 0: no surface
uniform sampler2D u_normals;  // RGB32F, camera frame, zero: no surface
uniform vec3 u_background;

void main() {
  ivec2 size = textureSize(u_depth, 0);
  ivec2 p = clamp(ivec2(floor(v_uv * vec2(size))), ivec2(0), size - 1);
  float d = texelFetch(u_depth, p, 0).r;
  vec3 n = texelFetch(u_normals, p, 0).xyz;
  if (!(d > 0.0) || n == vec3(0.0)) {
    frag_colour = vec4(u_background, 1.0);
    return;
  }
  frag_colour = vec4(0.5 + 0.5 * vec3(n.x, -n.y, -n.z), 1.0);
}
