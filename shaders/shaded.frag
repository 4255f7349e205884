#version 330 core
// Model raycast shaded by multi-view AO: grey = ao * (ambient + (1 - ambient) * max(0, n . l)).
// Mirrors shade_mvao() in src/render/composite.cpp.
in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_depth;    // R32F, metres, <= 0: no surface
uniform sampler2D u_normals;  // RGB32F, camera frame, zero: no surface
uniform sampler2D u_ao;       // R32F, [0, 1], < 0: unobserved (counts as 1)
uniform vec3 u_to_light;      // camera frame, unit
uniform float u_ambient;
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
  float ao = texelFetch(u_ao, p, 0).r;
  ao = ao >= 0.0 ? min(ao, 1.0) : 1.0;
  float grey = ao * (u_ambient + (1.0 - u_ambient) * max(0.0, dot(n, u_to_light)));
  frag_colour = vec4(vec3(grey), 1.0);
}
