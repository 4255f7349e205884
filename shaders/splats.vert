#version 330 core
// Splats view, passes 1 and 2: each vertex of the fused surface is a screen-aligned disk drawn as
// a GL point holding it, grey = AO x diffuse as in the orbit view. Mirrors composite_splats() in
// src/render/composite.cpp.
layout(location = 0) in vec3 a_position_world;
layout(location = 1) in vec3 a_normal_world;  // zero when the mesh has no normal there
layout(location = 2) in float a_ao;           // [0, 1]

uniform mat4 u_eye_from_world;
uniform mat4 u_clip_from_eye;
uniform vec3 u_to_light_eye;  // GL eye coordinates (y up, z backwards), unit
uniform float u_ambient;
uniform vec2 u_viewport_size;  // pixels
uniform float u_radius_px_m;   // disk radius in pixels x eye depth (m)
uniform float u_epsilon_m;     // the blending depth: splats are pushed back by this in pass 1
uniform float u_min_radius_px;
uniform float u_max_radius_px;

flat out vec2 v_centre_px;  // window coordinates of the centre
flat out float v_radius_px;
flat out float v_depth_back;  // window depth of the centre pushed back by u_epsilon_m
flat out float v_grey;

void main() {
  vec4 eye = u_eye_from_world * vec4(a_position_world, 1.0);
  vec4 clip = u_clip_from_eye * eye;
  gl_Position = clip;
  vec4 back = u_clip_from_eye * vec4(eye.xy, eye.z - u_epsilon_m, 1.0);
  v_depth_back = back.z / back.w * 0.5 + 0.5;
  v_centre_px = (clip.xy / clip.w * 0.5 + 0.5) * u_viewport_size;
  v_radius_px = clamp(u_radius_px_m / -eye.z, u_min_radius_px, u_max_radius_px);
  gl_PointSize = 2.0 * v_radius_px + 1.0;  // the whole disk, with a pixel to spare
  float shade = a_ao;
  if (a_normal_world != vec3(0.0)) {
    vec3 n = normalize(mat3(u_eye_from_world) * a_normal_world);
    shade *= u_ambient + (1.0 - u_ambient) * max(0.0, dot(n, u_to_light_eye));
  }
  v_grey = shade;
}
