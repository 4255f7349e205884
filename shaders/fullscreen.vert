#version 330 core
// One triangle covering the viewport. v_uv runs over the image: (0, 0) at the top-left corner of
// the top-left pixel, (1, 1) at the bottom-right corner (image rows go down, GL rows go up).
out vec2 v_uv;

void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));  // (0,0) (2,0) (0,2)
  v_uv = vec2(p.x, 1.0 - p.y);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
