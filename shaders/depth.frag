#version 330 core
// Depth through a 5-stop blue-cyan-green-yellow-red map over [u_depth_min, u_depth_max].
// Mirrors shade_depth() in src/render/composite.cpp (same stops).
in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_depth;  // R32F, metres, <= 0: invalid
uniform float u_depth_min;
uniform float u_depth_max;
uniform vec3 u_background;

const vec3 kStops[5] = vec3[5](vec3(26.0, 26.0, 153.0), vec3(0.0, 179.0, 230.0),
                               vec3(51.0, 204.0, 51.0), vec3(242.0, 217.0, 26.0),
                               vec3(204.0, 26.0, 26.0));  // 8-bit values

void main() {
  ivec2 size = textureSize(u_depth, 0);
  ivec2 p = clamp(ivec2(floor(v_uv * vec2(size))), ivec2(0), size - 1);
  float d = texelFetch(u_depth, p, 0).r;
  if (!(d > 0.0)) {
    frag_colour = vec4(u_background, 1.0);
    return;
  }
  float range = max(u_depth_max - u_depth_min, 1e-6);
  float t = clamp((d - u_depth_min) / range, 0.0, 1.0);
  int i = min(int(t * 4.0), 3);
  float f = t * 4.0 - float(i);
  frag_colour = vec4((kStops[i] + (kStops[i + 1] - kStops[i]) * f) / 255.0, 1.0);
}
