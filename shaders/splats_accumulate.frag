#version 330 core
// Splats view, pass 2: adds (w x grey, w) of each splat's disk where its depth passes the test
// against pass 1's (LEQUAL, no depth writes), w = exp(-d^2 / (2 sigma^2)), sigma = r / 2. Mirrors
// composite_splats() in src/render/composite.cpp.
flat in vec2 v_centre_px;
flat in float v_radius_px;
flat in float v_grey;
out vec4 frag_sums;

void main() {
  vec2 d = gl_FragCoord.xy - v_centre_px;
  float d2 = dot(d, d);
  float r2 = v_radius_px * v_radius_px;
  if (d2 >= r2) discard;
  float w = exp(-d2 * (2.0 / r2));
  frag_sums = vec4(w * v_grey, w, 0.0, 0.0);
}
