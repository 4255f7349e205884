#version 330 core
// Orbit view: each vertex of the fused surface is a square point, grey = AO x diffuse with a light
// fixed to the orbit camera. Mirrors composite_orbit() in src/render/composite.cpp.
layout(location = 0) in vec3 a_position_world;
layout(location = 1) in vec3 a_normal_world;  // zero when the mesh has no normal there
layout(location = 2) in float a_ao;           // [0, 1]

uniform mat4 u_clip_from_world;
uniform mat3 u_eye_R_world;
uniform vec3 u_to_light_eye;  // GL eye coordinates (y up, z backwards), unit
uniform float u_ambient;
uniform float u_point_size;

flat out float v_grey;

void main() {
  gl_Position = u_clip_from_world * vec4(a_position_world, 1.0);
  gl_PointSize = u_point_size;
  float shade = a_ao;
  if (a_normal_world != vec3(0.0)) {
    vec3 n = normalize(u_eye_R_world * a_normal_world);
    shade *= u_ambient + (1.0 - u_ambient) * max(0.0, dot(n, u_to_light_eye));
  }
  v_grey = shade;
}
