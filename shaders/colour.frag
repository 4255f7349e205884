#version 330 core
// The fused colour of the model raycast (colour view), times the multi-view AO with u_with_ao
// (colour_mvao view; no diffuse term). Mirrors shade_colour() and shade_colour_mvao() in
// src/render/composite.cpp. A frame without colour is drawn by shaded.frag instead.
in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_depth;    // R32F, metres, <= 0: no surface
uniform sampler2D u_normals;  // RGB32F, camera frame, zero: no surface
uniform sampler2D u_colour;   // RGB8, the fused colour
uniform sampler2D u_ao;       // R32F, [0, 1], < 0: unobserved (counts as 1)
uniform int u_with_ao;
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
  vec3 c = texelFetch(u_colour, p, 0).rgb;
  if (u_with_ao != 0) {
    float ao = texelFetch(u_ao, p, 0).r;
    c *= ao >= 0.0 ? min(ao, 1.0) : 1.0;
  }
  frag_colour = vec4(c, 1.0);
}
