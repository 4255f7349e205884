#version 330 core
// Splats view, pass 1: the depth of each splat's disk pushed back by the blending depth (no
// colour). Mirrors composite_splats() in src/render/composite.cpp.
flat in vec2 v_centre_px;
flat in float v_radius_px;
flat in float v_depth_back;

void main() {
  vec2 d = gl_FragCoord.xy - v_centre_px;
  if (dot(d, d) >= v_radius_px * v_radius_px) discard;
  gl_FragDepth = v_depth_back;
}
