#version 330 core
// The frame's SSAO as grey. Mirrors shade_ssao() in src/render/composite.cpp.
in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_ssao;  // R32F, [0, 1], < 0: no data
uniform vec3 u_background;

void main() {
  ivec2 size = textureSize(u_ssao, 0);
  ivec2 p = clamp(ivec2(floor(v_uv * vec2(size))), ivec2(0), size - 1);
  float ao = texelFetch(u_ssao, p, 0).r;
  frag_colour = ao >= 0.0 ? vec4(vec3(min(ao, 1.0)), 1.0) : vec4(u_background, 1.0);
}
