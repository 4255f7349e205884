#version 330 core
// Splats view, pass 3: grey = sum(w x grey) / sum(w) of pass 2, the background where no splat
// covers the pixel. Mirrors composite_splats() in src/render/composite.cpp.
out vec4 frag_colour;

uniform sampler2D u_sums;  // RG32F, the view's size: (sum of w x grey, sum of w)
uniform vec2 u_origin;     // window coordinates of the view's bottom-left corner
uniform vec3 u_background;

void main() {
  vec2 sums = texelFetch(u_sums, ivec2(gl_FragCoord.xy - u_origin), 0).rg;
  frag_colour = vec4(sums.y > 0.0 ? vec3(sums.x / sums.y) : u_background, 1.0);
}
