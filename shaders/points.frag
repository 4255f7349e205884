#version 330 core
flat in float v_grey;
out vec4 frag_colour;

void main() { frag_colour = vec4(vec3(v_grey), 1.0); }
