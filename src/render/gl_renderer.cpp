/// @file gl_renderer.cpp
/// @brief Shader programs, textures and draw calls of the live view.
#include "render/gl_renderer.h"

#include <algorithm>
#include <cmath>

#include "render/shaders.h"

namespace aoscan {
namespace {

/// The compiler's log, first line only (messages stay one line).
std::string first_line(std::string log) {
  const std::size_t end = log.find_first_of("\r\n");
  if (end != std::string::npos) log.resize(end);
  return log.empty() ? "no log" : log;
}

/// Compiles one shader; 0 with `error` on failure.
GLuint compile(const GlApi& gl, GLenum type, const std::string& file, const std::string& source,
               std::string& error) {
  const GLuint shader = gl.CreateShader(type);
  const char* text = source.c_str();
  gl.ShaderSource(shader, 1, &text, nullptr);
  gl.CompileShader(shader);
  GLint ok = GL_FALSE;
  gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok == GL_TRUE) return shader;
  GLint length = 0;
  gl.GetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  gl.GetShaderInfoLog(shader, length, nullptr, log.data());
  gl.DeleteShader(shader);
  error = "shader " + file + " does not compile: " + first_line(log.c_str());
  return 0;
}

}  // namespace

const std::vector<ProgramSpec>& program_specs() {
  static const std::vector<ProgramSpec> specs = {
      {"shaded", "fullscreen.vert", "shaded.frag"},
      {"ssao", "fullscreen.vert", "ssao.frag"},
      {"mvao", "fullscreen.vert", "mvao.frag"},
      {"colour", "fullscreen.vert", "colour.frag"},
      {"colour_mvao", "fullscreen.vert", "colour.frag"},  // u_with_ao = 1
      {"normals", "fullscreen.vert", "normals.frag"},
      {"depth", "fullscreen.vert", "depth.frag"},
      {"overlay", "fullscreen.vert", "overlay.frag"},
      {"orbit", "points.vert", "points.frag"},
      {"splats_depth", "splats.vert", "splats_depth.frag"},            // pass 1
      {"splats_accumulate", "splats.vert", "splats_accumulate.frag"},  // pass 2
      {"splats", "fullscreen.vert", "splats.frag"},                    // pass 3
  };
  return specs;
}

GlRect letterbox(int image_width, int image_height, int width, int height) {
  if (image_width <= 0 || image_height <= 0 || width <= 0 || height <= 0) return {};
  GlRect r;
  // Compare width / height ratios in integers: fit by width when the image is relatively wider.
  if (static_cast<long long>(image_width) * height >=
      static_cast<long long>(width) * image_height) {
    r.width = width;
    r.height = static_cast<int>(static_cast<long long>(width) * image_height / image_width);
  } else {
    r.height = height;
    r.width = static_cast<int>(static_cast<long long>(height) * image_width / image_height);
  }
  r.x = (width - r.width) / 2;
  r.y = (height - r.height) / 2;
  return r;
}

GlViewRenderer::~GlViewRenderer() {
  release();
}

void GlViewRenderer::release() {
  if (!gl_) return;
  for (auto& [name, program] : programs_) gl_->DeleteProgram(program);
  programs_.clear();
  gl_->DeleteTextures(kTextureCount, textures_.data());
  textures_ = {};
  texture_sizes_ = {};
  gl_->DeleteVertexArrays(1, &empty_vao_);
  gl_->DeleteVertexArrays(1, &points_vao_);
  gl_->DeleteBuffers(1, &points_vbo_);
  empty_vao_ = points_vao_ = points_vbo_ = 0;
  gl_->DeleteFramebuffers(1, &splat_framebuffer_);
  gl_->DeleteTextures(1, &splat_sums_);
  gl_->DeleteRenderbuffers(1, &splat_depth_);
  splat_framebuffer_ = splat_sums_ = splat_depth_ = 0;
  splat_size_ = {};
  gl_ = nullptr;
}

bool GlViewRenderer::init(const GlApi& gl, std::string& error, const ShaderOverrides& overrides) {
  release();
  gl_ = &gl;
  const auto source_of = [&](const char* file) -> std::string {
    if (auto it = overrides.find(file); it != overrides.end()) return it->second;
    const char* text = find_shader(file);
    return text ? text : "";
  };
  for (const ProgramSpec& spec : program_specs()) {
    for (const char* file : {spec.vertex, spec.fragment}) {
      if (source_of(file).empty()) {
        error = std::string("shader ") + file + " is not embedded";
        release();
        return false;
      }
    }
    const GLuint vs = compile(gl, GL_VERTEX_SHADER, spec.vertex, source_of(spec.vertex), error);
    if (!vs) {
      release();
      return false;
    }
    const GLuint fs =
        compile(gl, GL_FRAGMENT_SHADER, spec.fragment, source_of(spec.fragment), error);
    if (!fs) {
      gl.DeleteShader(vs);
      release();
      return false;
    }
    const GLuint program = gl.CreateProgram();
    gl.AttachShader(program, vs);
    gl.AttachShader(program, fs);
    gl.LinkProgram(program);
    gl.DeleteShader(vs);  // flagged; freed with the program
    gl.DeleteShader(fs);
    GLint ok = GL_FALSE;
    gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok != GL_TRUE) {
      GLint length = 0;
      gl.GetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
      std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
      gl.GetProgramInfoLog(program, length, nullptr, log.data());
      gl.DeleteProgram(program);
      error = std::string("program ") + spec.name + " (" + spec.vertex + " + " + spec.fragment +
              ") does not link: " + first_line(log.c_str());
      release();
      return false;
    }
    programs_[spec.name] = program;
  }
  gl.GenTextures(kTextureCount, textures_.data());
  for (GLuint texture : textures_) {
    gl.BindTexture(GL_TEXTURE_2D, texture);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  gl.GenVertexArrays(1, &empty_vao_);
  gl.GenVertexArrays(1, &points_vao_);
  gl.GenBuffers(1, &points_vbo_);
  gl.BindVertexArray(points_vao_);
  gl.BindBuffer(GL_ARRAY_BUFFER, points_vbo_);
  constexpr GLsizei kStride = 7 * sizeof(float);
  gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, kStride, reinterpret_cast<void*>(0));
  gl.VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, kStride,
                         reinterpret_cast<void*>(3 * sizeof(float)));
  gl.VertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, kStride,
                         reinterpret_cast<void*>(6 * sizeof(float)));
  for (GLuint a = 0; a < 3; ++a) gl.EnableVertexAttribArray(a);
  gl.BindVertexArray(0);
  if (const GLenum e = gl.GetError(); e != GL_NO_ERROR) {
    error = "OpenGL error " + std::to_string(e) + " while setting up the renderer";
    release();
    return false;
  }
  return true;
}

void GlViewRenderer::upload_float(Texture texture, const Image<float>* image, float no_data,
                                  int width, int height) {
  staging_.resize(static_cast<std::size_t>(width) * height);
  if (image) {
    const float* src = image->data();
    for (std::size_t i = 0; i < staging_.size(); ++i)
      staging_[i] = std::isnan(src[i]) ? no_data : src[i];
  } else {
    std::fill(staging_.begin(), staging_.end(), no_data);
  }
  set_texture(texture, GL_R32F, GL_RED, GL_FLOAT, width, height, staging_.data());
}

void GlViewRenderer::set_texture(Texture texture, GLint internal_format, GLenum format, GLenum type,
                                 int width, int height, const void* pixels) {
  gl_->BindTexture(GL_TEXTURE_2D, textures_[texture]);
  if (texture_sizes_[texture] == std::array<int, 2>{width, height}) {
    gl_->TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, format, type, pixels);
  } else {
    gl_->TexImage2D(GL_TEXTURE_2D, 0, internal_format, width, height, 0, format, type, pixels);
    texture_sizes_[texture] = {width, height};
  }
}

void GlViewRenderer::upload(const ViewFrame& frame, std::optional<View> only) {
  if (!gl_) return;
  const auto needs = [&](std::initializer_list<View> views) {
    return !only || std::find(views.begin(), views.end(), *only) != views.end();
  };
  const int width = std::max(frame.intrinsics.width, 1);
  const int height = std::max(frame.intrinsics.height, 1);
  gl_->PixelStorei(GL_UNPACK_ALIGNMENT, 1);
  // Each texture at its image's own size (the shaders map window pixels to texels through
  // textureSize); the depth, normal and MVAO textures share the depth's size, as the shaded view
  // reads them at one texel. What is missing is a texture of no-data at that size (1x1 alone).
  // The colour views fall back to the shaded view without colour: they need what it needs.
  const int model = image_scale(frame.depth_m, width, height);
  const int model_w = model > 0 ? frame.depth_m.width() : 1;
  const int model_h = model > 0 ? frame.depth_m.height() : 1;
  if (needs({View::kShaded, View::kMvao, View::kNormals, View::kColour, View::kColourMvao}))
    upload_float(kDepth, model > 0 ? &frame.depth_m : nullptr, 0.0f, model_w, model_h);
  if (needs({View::kShaded, View::kMvao, View::kColour, View::kColourMvao})) {
    const bool mvao_ok = model > 0 && image_scale(frame.mvao, width, height) == model;
    upload_float(kMvao, mvao_ok ? &frame.mvao : nullptr, -1.0f, model_w, model_h);
  }
  if (needs({View::kColour, View::kColourMvao})) {
    has_colour_ = model > 0 && image_scale(frame.colour, width, height) == model;
    if (has_colour_) {
      static_assert(sizeof(Rgb8) == 3, "colour rows are uploaded as packed RGB");
      set_texture(kColour, GL_RGB8, GL_RGB, GL_UNSIGNED_BYTE, model_w, model_h,
                  frame.colour.data());
    }
  }
  if (needs({View::kSsao})) {
    const bool ssao_ok = image_scale(frame.ssao, width, height) > 0;
    upload_float(kSsao, ssao_ok ? &frame.ssao : nullptr, -1.0f, ssao_ok ? frame.ssao.width() : 1,
                 ssao_ok ? frame.ssao.height() : 1);
  }
  if (needs({View::kDepth})) {
    has_raw_depth_ = image_scale(frame.raw_depth_m, width, height) > 0;
    if (has_raw_depth_)
      upload_float(kRawDepth, &frame.raw_depth_m, 0.0f, frame.raw_depth_m.width(),
                   frame.raw_depth_m.height());
  }
  if (needs({View::kShaded, View::kMvao, View::kNormals, View::kColour, View::kColourMvao})) {
    staging_.assign(static_cast<std::size_t>(model_w) * model_h * 3, 0.0f);
    if (model > 0 && image_scale(frame.normals, width, height) == model) {
      const Eigen::Vector3f* src = frame.normals.data();
      for (std::size_t i = 0; i < frame.normals.size(); ++i)
        if (src[i].allFinite())
          for (int c = 0; c < 3; ++c) staging_[3 * i + c] = src[i][c];
    }
    set_texture(kNormals, GL_RGB32F, GL_RGB, GL_FLOAT, model_w, model_h, staging_.data());
  }
  frame_width_ = width;
  frame_height_ = height;

  const TriangleMesh* surface = frame.surface.get();
  if (needs({View::kOrbit, View::kSplats}) && surface != uploaded_surface_) {
    surface_ = frame.surface;
    uploaded_surface_ = surface;
    point_count_ = 0;
    surface_edge_m_ = 0.0f;
    if (surface) {
      surface_edge_m_ = mean_edge_length_m(*surface);
      const std::size_t n = surface->vertices.size();
      staging_.resize(7 * n);
      for (std::size_t i = 0; i < n; ++i) {
        float* v = &staging_[7 * i];
        const Eigen::Vector3f& p = surface->vertices[i];
        const Eigen::Vector3f normal = vertex_normal(*surface, i);
        for (int c = 0; c < 3; ++c) {
          v[c] = p[c];
          v[3 + c] = normal[c];
        }
        v[6] = vertex_ao(*surface, i);
      }
      gl_->BindBuffer(GL_ARRAY_BUFFER, points_vbo_);
      gl_->BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(staging_.size() * sizeof(float)),
                      staging_.data(), GL_STATIC_DRAW);
      point_count_ = static_cast<GLsizei>(n);
    }
  }
}

void GlViewRenderer::bind_texture(GLuint program, const char* uniform, Texture texture, int unit) {
  gl_->ActiveTexture(GL_TEXTURE0 + unit);
  gl_->BindTexture(GL_TEXTURE_2D, textures_[texture]);
  gl_->Uniform1i(gl_->GetUniformLocation(program, uniform), unit);
}

void GlViewRenderer::draw(View view, const GlRect& rect, const ViewStyle& style,
                          const OrbitCamera& orbit) {
  if (!gl_ || rect.width <= 0 || rect.height <= 0) return;
  const GlApi& gl = *gl_;
  gl.Viewport(rect.x, rect.y, rect.width, rect.height);
  gl.Disable(GL_BLEND);
  const bool colour_view = view == View::kColour || view == View::kColourMvao;
  if (colour_view && !has_colour_) view = View::kShaded;  // a frame without colour
  const GLuint program = programs_.at(view_name(view));
  if (view == View::kSplats) {
    draw_splats(program, rect, style, orbit);
    return;
  }
  gl.UseProgram(program);
  const auto uniform = [&](const char* name) { return gl.GetUniformLocation(program, name); };
  const Rgb8 bg = style.background;
  gl.Uniform3f(uniform("u_background"), bg.r / 255.0f, bg.g / 255.0f, bg.b / 255.0f);

  if (view == View::kOrbit) {
    if (point_count_ == 0) return;
    Eigen::Matrix4f eye_from_world;
    const Eigen::Matrix4f clip_from_world = orbit_clip_from_world(
        orbit, static_cast<float>(rect.width) / static_cast<float>(rect.height), &eye_from_world);
    const Eigen::Matrix3f eye_R_world = eye_from_world.topLeftCorner<3, 3>();
    gl.UniformMatrix4fv(uniform("u_clip_from_world"), 1, GL_FALSE, clip_from_world.data());
    gl.UniformMatrix3fv(uniform("u_eye_R_world"), 1, GL_FALSE, eye_R_world.data());
    const Eigen::Vector3f& l = style.to_light_camera;
    gl.Uniform3f(uniform("u_to_light_eye"), l.x(), -l.y(), -l.z());
    gl.Uniform1f(uniform("u_ambient"), style.ambient);
    gl.Uniform1f(uniform("u_point_size"), style.point_size_px);
    gl.Enable(GL_PROGRAM_POINT_SIZE);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_LESS);
    gl.ClearDepth(1.0);
    gl.Clear(GL_DEPTH_BUFFER_BIT);
    gl.BindVertexArray(points_vao_);
    gl.DrawArrays(GL_POINTS, 0, point_count_);
    gl.BindVertexArray(0);
    gl.Disable(GL_DEPTH_TEST);
    return;
  }
  if (frame_width_ == 0) return;
  switch (view) {
    case View::kShaded:
      bind_texture(program, "u_depth", kDepth, 0);
      bind_texture(program, "u_normals", kNormals, 1);
      bind_texture(program, "u_ao", kMvao, 2);
      gl.Uniform3f(uniform("u_to_light"), style.to_light_camera.x(), style.to_light_camera.y(),
                   style.to_light_camera.z());
      gl.Uniform1f(uniform("u_ambient"), style.ambient);
      break;
    case View::kSsao:
      bind_texture(program, "u_ssao", kSsao, 0);
      break;
    case View::kMvao:
      bind_texture(program, "u_depth", kDepth, 0);
      bind_texture(program, "u_normals", kNormals, 1);
      bind_texture(program, "u_ao", kMvao, 2);
      break;
    case View::kColour:
    case View::kColourMvao:
      bind_texture(program, "u_depth", kDepth, 0);
      bind_texture(program, "u_normals", kNormals, 1);
      bind_texture(program, "u_colour", kColour, 2);
      bind_texture(program, "u_ao", kMvao, 3);
      gl.Uniform1i(uniform("u_with_ao"), view == View::kColourMvao ? 1 : 0);
      break;
    case View::kNormals:
      bind_texture(program, "u_depth", kDepth, 0);
      bind_texture(program, "u_normals", kNormals, 1);
      break;
    case View::kDepth:
      bind_texture(program, "u_depth", has_raw_depth_ ? kRawDepth : kDepth, 0);
      gl.Uniform1f(uniform("u_depth_min"), style.depth_min_m);
      gl.Uniform1f(uniform("u_depth_max"), style.depth_max_m);
      break;
    case View::kOrbit:
    case View::kSplats:
      break;
  }
  gl.BindVertexArray(empty_vao_);
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.BindVertexArray(0);
}

bool GlViewRenderer::ensure_splat_target(int width, int height) {
  const GlApi& gl = *gl_;
  if (splat_framebuffer_ == 0) {
    gl.GenFramebuffers(1, &splat_framebuffer_);
    gl.GenTextures(1, &splat_sums_);
    gl.GenRenderbuffers(1, &splat_depth_);
    gl.BindTexture(GL_TEXTURE_2D, splat_sums_);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  }
  gl.BindFramebuffer(GL_FRAMEBUFFER, splat_framebuffer_);
  if (splat_size_ != std::array<int, 2>{width, height}) {
    gl.BindTexture(GL_TEXTURE_2D, splat_sums_);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RG32F, width, height, 0, GL_RG, GL_FLOAT, nullptr);
    gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, splat_sums_, 0);
    gl.BindRenderbuffer(GL_RENDERBUFFER, splat_depth_);
    gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
    gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, splat_depth_);
    splat_size_ = {width, height};
  }
  return gl.CheckFramebufferStatus(GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE;
}

void GlViewRenderer::draw_splats(GLuint program, const GlRect& rect, const ViewStyle& style,
                                 const OrbitCamera& orbit) {
  const GlApi& gl = *gl_;
  if (point_count_ == 0) return;
  GLint target = 0;  // the caller's framebuffer, where pass 3 draws
  gl.GetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &target);
  if (!ensure_splat_target(rect.width, rect.height)) {
    gl.BindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(target));
    return;
  }
  Eigen::Matrix4f eye_from_world;
  Eigen::Matrix4f clip_from_eye;
  orbit_clip_from_world(orbit, static_cast<float>(rect.width) / static_cast<float>(rect.height),
                        &eye_from_world, &clip_from_eye);
  const float spacing_m = surface_edge_m_ > 0.0f ? surface_edge_m_ : style.splat_spacing_m;
  const float radius_m = style.splat_radius_per_spacing * spacing_m;
  const Eigen::Vector3f& l = style.to_light_camera;
  gl.Viewport(0, 0, rect.width, rect.height);
  const GLfloat zeros[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const GLfloat far_depth = 1.0f;
  gl.ClearBufferfv(GL_COLOR, 0, zeros);
  gl.ClearBufferfv(GL_DEPTH, 0, &far_depth);
  gl.Enable(GL_PROGRAM_POINT_SIZE);
  gl.Enable(GL_DEPTH_TEST);
  gl.BindVertexArray(points_vao_);
  for (const bool depth_pass : {true, false}) {
    const GLuint p = programs_.at(depth_pass ? "splats_depth" : "splats_accumulate");
    gl.UseProgram(p);
    const auto uniform = [&](const char* name) { return gl.GetUniformLocation(p, name); };
    gl.UniformMatrix4fv(uniform("u_eye_from_world"), 1, GL_FALSE, eye_from_world.data());
    gl.UniformMatrix4fv(uniform("u_clip_from_eye"), 1, GL_FALSE, clip_from_eye.data());
    gl.Uniform3f(uniform("u_to_light_eye"), l.x(), -l.y(), -l.z());
    gl.Uniform1f(uniform("u_ambient"), style.ambient);
    gl.Uniform2f(uniform("u_viewport_size"), static_cast<float>(rect.width),
                 static_cast<float>(rect.height));
    gl.Uniform1f(uniform("u_radius_px_m"),
                 radius_m * clip_from_eye(1, 1) * 0.5f * static_cast<float>(rect.height));
    gl.Uniform1f(uniform("u_epsilon_m"), radius_m);  // the blending depth: one splat radius
    gl.Uniform1f(uniform("u_min_radius_px"), kSplatMinRadiusPx);
    gl.Uniform1f(uniform("u_max_radius_px"), kSplatMaxRadiusPx);
    // Pass 1 writes the nearest pushed-back depth, no colour; pass 2 adds up the sums of the
    // fragments not behind it, without writing depth.
    gl.ColorMask(!depth_pass, !depth_pass, !depth_pass, !depth_pass);
    gl.DepthMask(depth_pass ? GL_TRUE : GL_FALSE);
    gl.DepthFunc(depth_pass ? GL_LESS : GL_LEQUAL);
    if (depth_pass) {
      gl.Disable(GL_BLEND);
    } else {
      gl.Enable(GL_BLEND);
      gl.BlendFunc(GL_ONE, GL_ONE);
    }
    gl.DrawArrays(GL_POINTS, 0, point_count_);
  }
  gl.Disable(GL_BLEND);
  gl.Disable(GL_DEPTH_TEST);
  gl.DepthMask(GL_TRUE);
  gl.DepthFunc(GL_LESS);

  // Pass 3: normalise into the caller's rectangle.
  gl.BindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(target));
  gl.Viewport(rect.x, rect.y, rect.width, rect.height);
  gl.UseProgram(program);
  const Rgb8 bg = style.background;
  gl.Uniform3f(gl.GetUniformLocation(program, "u_background"), bg.r / 255.0f, bg.g / 255.0f,
               bg.b / 255.0f);
  gl.Uniform2f(gl.GetUniformLocation(program, "u_origin"), static_cast<float>(rect.x),
               static_cast<float>(rect.y));
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D, splat_sums_);
  gl.Uniform1i(gl.GetUniformLocation(program, "u_sums"), 0);
  gl.BindVertexArray(empty_vao_);
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.BindVertexArray(0);
}

void GlViewRenderer::draw_overlay(const Image<Rgba8>& overlay, int x, int y,
                                  int framebuffer_height) {
  if (!gl_ || overlay.empty()) return;
  const GlApi& gl = *gl_;
  static_assert(sizeof(Rgba8) == 4, "overlay rows are uploaded as packed RGBA");
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
  set_texture(kOverlay, GL_RGBA8, GL_RGBA, GL_UNSIGNED_BYTE, overlay.width(), overlay.height(),
              overlay.data());
  gl.Viewport(x, framebuffer_height - y - overlay.height(), overlay.width(), overlay.height());
  const GLuint program = programs_.at("overlay");
  gl.UseProgram(program);
  bind_texture(program, "u_overlay", kOverlay, 0);
  gl.Enable(GL_BLEND);
  gl.BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  gl.BindVertexArray(empty_vao_);
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.BindVertexArray(0);
  gl.Disable(GL_BLEND);
}

GlOffscreenTarget::~GlOffscreenTarget() {
  if (!gl_) return;
  gl_->BindFramebuffer(GL_FRAMEBUFFER, 0);
  gl_->DeleteFramebuffers(1, &framebuffer_);
  gl_->DeleteTextures(1, &colour_);
  gl_->DeleteRenderbuffers(1, &depth_);
}

bool GlOffscreenTarget::create(const GlApi& gl, int width, int height, std::string& error) {
  gl_ = &gl;
  width_ = width;
  height_ = height;
  gl.GenFramebuffers(1, &framebuffer_);
  gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  gl.GenTextures(1, &colour_);
  gl.BindTexture(GL_TEXTURE_2D, colour_);
  gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  gl.FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_, 0);
  gl.GenRenderbuffers(1, &depth_);
  gl.BindRenderbuffer(GL_RENDERBUFFER, depth_);
  gl.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, width, height);
  gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  const GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    error = "offscreen framebuffer incomplete (status " + std::to_string(status) + ")";
    return false;
  }
  return true;
}

void GlOffscreenTarget::bind() const {
  gl_->BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
}

void GlOffscreenTarget::read(Image<Rgb8>& out) const {
  static_assert(sizeof(Rgb8) == 3, "read back as packed RGB");
  out.resize(width_, height_);
  std::vector<Rgb8> rows(static_cast<std::size_t>(width_) * height_);
  gl_->BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  gl_->PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl_->ReadPixels(0, 0, width_, height_, GL_RGB, GL_UNSIGNED_BYTE, rows.data());
  for (int y = 0; y < height_; ++y)  // GL row 0 is the bottom
    std::copy_n(rows.data() + static_cast<std::size_t>(height_ - 1 - y) * width_, width_,
                out.row(y));
}

}  // namespace aoscan
