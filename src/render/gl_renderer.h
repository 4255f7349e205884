/// @file gl_renderer.h
/// @brief The GL side of the live view: the shader programs, the frame's images as textures, and
/// drawing one view (or the HUD overlay) into a rectangle of the bound framebuffer. Knows nothing
/// of windows (see gl_window.h); needs a current OpenGL 3.3 core context.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "render/composite.h"
#include "render/gl_api.h"
#include "render/hud.h"
#include "render/view_frame.h"

namespace aoscan {

/// Test hook: replacement sources by shader file name (e.g. {"shaded.frag", "broken"}).
using ShaderOverrides = std::map<std::string, std::string>;

/// A GL program built from two embedded shader files.
struct ProgramSpec {
  const char* name;  ///< the view or pass it draws
  const char* vertex;
  const char* fragment;
};
/// Every program the renderer builds.
const std::vector<ProgramSpec>& program_specs();

/// A window-space rectangle in pixels, origin at the bottom-left (GL convention).
struct GlRect {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
};

/// The largest rectangle of aspect `image_width : image_height` centred in a `width` x `height`
/// framebuffer.
GlRect letterbox(int image_width, int image_height, int width, int height);

class GlViewRenderer {
 public:
  GlViewRenderer() = default;
  GlViewRenderer(const GlViewRenderer&) = delete;
  GlViewRenderer& operator=(const GlViewRenderer&) = delete;
  /// Frees the GL objects; the context must still be current.
  ~GlViewRenderer();

  /// Compiles and links every program, makes the textures. False with a one-line `error` naming
  /// the shader file (and the compiler's first message) on failure.
  bool init(const GlApi& gl, std::string& error, const ShaderOverrides& overrides = {});

  /// Uploads the images of `frame` (NaN and mismatched sizes become the views' "no data") and, when
  /// its surface pointer changed, the surface's vertices. With `only`, just what that view draws
  /// (the live view uploads its current view's data, again when the view changes: software GL
  /// copies every texture on the CPU that fusion runs on).
  void upload(const ViewFrame& frame, std::optional<View> only = std::nullopt);
  /// Draws `view` of the last uploaded frame into `rect` of the bound framebuffer. The orbit view
  /// clears the depth buffer; the caller clears colour. The splats view draws its first two passes
  /// into a float framebuffer of the renderer's own (rect's size) and its third into `rect`.
  void draw(View view, const GlRect& rect, const ViewStyle& style, const OrbitCamera& orbit);
  /// Blends `overlay` (e.g. the HUD) with its top-left corner at image pixel (x, y) of a
  /// framebuffer `framebuffer_height` pixels high.
  void draw_overlay(const Image<Rgba8>& overlay, int x, int y, int framebuffer_height);

  /// Size of the last uploaded frame's images (0 x 0 before the first upload).
  int frame_width() const { return frame_width_; }
  int frame_height() const { return frame_height_; }

 private:
  enum Texture { kDepth, kNormals, kSsao, kMvao, kColour, kRawDepth, kOverlay, kTextureCount };
  void release();
  /// The splats view's three passes (see composite.h); `program` is its normalising pass.
  void draw_splats(GLuint program, const GlRect& rect, const ViewStyle& style,
                   const OrbitCamera& orbit);
  /// Makes (or resizes) the splats view's float target: RG32F sums + 32-bit float depth.
  bool ensure_splat_target(int width, int height);
  void upload_float(Texture texture, const Image<float>* image, float no_data, int width,
                    int height);
  void bind_texture(GLuint program, const char* uniform, Texture texture, int unit);
  /// Fills `texture` from `pixels`, reallocating its storage only when the size changed.
  void set_texture(Texture texture, GLint internal_format, GLenum format, GLenum type, int width,
                   int height, const void* pixels);

  const GlApi* gl_ = nullptr;
  std::map<std::string, GLuint> programs_;
  std::array<GLuint, kTextureCount> textures_{};
  std::array<std::array<int, 2>, kTextureCount> texture_sizes_{};
  GLuint empty_vao_ = 0;
  GLuint points_vao_ = 0;
  GLuint points_vbo_ = 0;
  GLsizei point_count_ = 0;
  float surface_edge_m_ = 0.0f;  ///< mean_edge_length_m() of the uploaded surface
  GLuint splat_framebuffer_ = 0;
  GLuint splat_sums_ = 0;   ///< RG32F texture: (sum of w x grey, sum of w)
  GLuint splat_depth_ = 0;  ///< 32-bit float depth renderbuffer
  std::array<int, 2> splat_size_{};
  const TriangleMesh* uploaded_surface_ = nullptr;
  std::shared_ptr<const TriangleMesh> surface_;  ///< keeps uploaded_surface_ alive
  bool has_raw_depth_ = false;
  bool has_colour_ = false;  ///< the colour views draw the colour; else they draw shaded
  int frame_width_ = 0;
  int frame_height_ = 0;
  std::vector<float> staging_;
};

/// An offscreen RGBA8 + 32-bit float depth framebuffer (tests and headless GL read-backs).
class GlOffscreenTarget {
 public:
  GlOffscreenTarget() = default;
  GlOffscreenTarget(const GlOffscreenTarget&) = delete;
  GlOffscreenTarget& operator=(const GlOffscreenTarget&) = delete;
  ~GlOffscreenTarget();

  /// Makes and binds the framebuffer; false with `error` when incomplete.
  bool create(const GlApi& gl, int width, int height, std::string& error);
  void bind() const;
  /// Reads the colour back into `out` (image row 0 = top) with glReadPixels.
  void read(Image<Rgb8>& out) const;

 private:
  const GlApi* gl_ = nullptr;
  GLuint framebuffer_ = 0;
  GLuint colour_ = 0;
  GLuint depth_ = 0;
  int width_ = 0;
  int height_ = 0;
};

}  // namespace aoscan
