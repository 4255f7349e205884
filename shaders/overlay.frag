#version 330 core
// The HUD overlay (RGBA8, drawn with the viewport set to its rectangle, blended by alpha).
in vec2 v_uv;
out vec4 frag_colour;

uniform sampler2D u_overlay;

void main() {
  ivec2 size = textureSize(u_overlay, 0);
  ivec2 p = clamp(ivec2(floor(v_uv * vec2(size))), ivec2(0), size - 1);
  frag_colour = texelFetch(u_overlay, p, 0);
}
