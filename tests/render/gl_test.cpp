/// @file gl_test.cpp
/// @brief The GL path against the CPU composite on analytic frames, shader compilation, and the
/// live view's fall-backs. Needs a display with OpenGL 3.3 (tools/test.sh runs the suite under
/// `xvfb-run -a -s "-noreset"` with Mesa's software rasteriser); skips with a message when there
/// is none. Without -noreset Xvfb resets whenever its last client leaves, and a window opened
/// during the reset fails: the helpers below retry once in that case.
#include <dlfcn.h>
#include <unistd.h>
#include <chrono>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "render/composite.h"
#include "render/gl_renderer.h"
#include "render/gl_window.h"
#include "render/hud.h"
#include "render/live_view.h"
#include "render/render_test_util.h"
#include "support/private_xvfb.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

/// Largest per-channel difference allowed for a pixel to count as matching, and the share of
/// pixels that must match. Differences come from float rounding in the shaders (e.g. division,
/// normalize) landing on the other side of a .5 in the 8-bit conversion.
constexpr int kMaxChannelDiff = 2;
constexpr double kMinMatchingShare = 0.999;

/// Every view drawn from the frame's images (all but the orbit view).
constexpr View kImageViews[] = {View::kShaded,     View::kSsao,    View::kMvao, View::kColour,
                                View::kColourMvao, View::kNormals, View::kDepth};

struct Comparison {
  double matching_share = 0.0;
  int max_diff = 0;
};

Comparison compare(const Image<Rgb8>& a, const Image<Rgb8>& b) {
  Comparison c;
  if (a.width() != b.width() || a.height() != b.height() || a.empty()) return c;
  std::size_t matching = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      const Rgb8 p = a(x, y);
      const Rgb8 q = b(x, y);
      const int d = std::max({std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)});
      c.max_diff = std::max(c.max_diff, d);
      matching += d <= kMaxChannelDiff;
    }
  c.matching_share = static_cast<double>(matching) / static_cast<double>(a.size());
  return c;
}

/// True for the transient failure of connecting while Xvfb resets.
bool display_resetting(const std::string& error) {
  return error.find("Failed to open display") != std::string::npos;
}

std::unique_ptr<GlWindow> create_window(const WindowOptions& options, std::string& error) {
  std::unique_ptr<GlWindow> window = GlWindow::create(options, error);
  if (!window && display_resetting(error)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    window = GlWindow::create(options, error);
  }
  return window;
}

LiveViewResult run_view(const LiveViewOptions& options, const ViewFeed& feed,
                        ViewCommandQueue& commands, const std::atomic<bool>& stop) {
  LiveViewResult r = run_live_view(options, feed, commands, stop);
  if (r.outcome == LiveViewResult::Outcome::kUnavailable && display_resetting(r.message)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    r = run_live_view(options, feed, commands, stop);
  }
  return r;
}

/// Makes every shared library mapped now resident for the rest of the process. glfwTerminate()
/// unloads libGL and with it Mesa's driver, whose allocations of its own lifetime then show up
/// as leaks from an "unknown module" under LeakSanitizer; pinned, they stay reachable.
void pin_loaded_libraries() {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line)) {
    const std::size_t slash = line.find('/');
    if (slash == std::string::npos || line.find(".so", slash) == std::string::npos) continue;
    const std::string path = line.substr(slash);
    if (void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE))
      dlclose(handle);  // drops our reference; NODELETE keeps the library mapped
  }
}

/// A hidden window whose context the tests draw with (into an offscreen framebuffer).
class GlTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string error;
    WindowOptions options;
    options.width = 64;
    options.height = 64;
    options.visible = false;
    window_ = create_window(options, error);
    if (!window_) GTEST_SKIP() << "no OpenGL 3.3 context (" << error << "); run under xvfb-run";
    pin_loaded_libraries();
  }
  void TearDown() override { window_.reset(); }

  /// A renderer and a w x h offscreen target on this test's context.
  void make_rig(GlViewRenderer& renderer, GlOffscreenTarget& target, int w, int h) {
    std::string error;
    ASSERT_TRUE(renderer.init(window_->gl(), error)) << error;
    ASSERT_TRUE(target.create(window_->gl(), w, h, error)) << error;
  }

  /// Renders `view` of `frame` at the frame's size through GL and reads it back; `view_only`
  /// uploads only what the view draws, as the live view does.
  Image<Rgb8> render_gl(const ViewFrame& frame, View view, const ViewStyle& style,
                        const OrbitCamera& orbit = {}, bool view_only = false) {
    const GlApi& gl = window_->gl();
    GlViewRenderer renderer;
    GlOffscreenTarget target;
    make_rig(renderer, target, frame.intrinsics.width, frame.intrinsics.height);
    target.bind();
    const Rgb8 bg = style.background;
    gl.Viewport(0, 0, frame.intrinsics.width, frame.intrinsics.height);
    gl.ClearColor(bg.r / 255.0f, bg.g / 255.0f, bg.b / 255.0f, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT);
    if (view_only)
      renderer.upload(frame, view);
    else
      renderer.upload(frame);
    renderer.draw(view, {0, 0, frame.intrinsics.width, frame.intrinsics.height}, style, orbit);
    Image<Rgb8> out;
    target.read(out);
    EXPECT_EQ(gl.GetError(), static_cast<GLenum>(GL_NO_ERROR));
    return out;
  }

  std::unique_ptr<GlWindow> window_;
};

TEST_F(GlTest, EveryShaderCompilesAndLinks) {
  std::string error;
  GlViewRenderer renderer;
  ASSERT_TRUE(renderer.init(window_->gl(), error)) << error;
  EXPECT_GE(window_->gl().version(), 33);
  std::printf("[ info ] GL renderer: %s\n", window_->renderer().c_str());
}

TEST_F(GlTest, ImageViewsMatchTheCpuComposite) {
  ViewFrame with_colour = testing::sphere_wall_frame(160, 120);
  ViewFrame without_colour = with_colour;
  without_colour.colour = Image<Rgb8>();  // the colour views show the shaded view
  ViewStyle style;  // the default light: non-trivial diffuse everywhere
  for (const ViewFrame* frame : {&with_colour, &without_colour}) {
    for (const bool view_only : {false, true}) {
      for (View view : kImageViews) {
        Image<Rgb8> cpu;
        composite_view(*frame, view, cpu, style);
        const Image<Rgb8> gpu = render_gl(*frame, view, style, {}, view_only);
        const Comparison c = compare(cpu, gpu);
        std::printf("[ info ] %-11s%s%s matching %.5f, max diff %d\n", view_name(view),
                    frame == &without_colour ? " (no colour)" : "",
                    view_only ? " (its data only)" : "", c.matching_share, c.max_diff);
        EXPECT_GE(c.matching_share, kMinMatchingShare) << view_name(view);
        EXPECT_LE(c.max_diff, 8) << view_name(view);  // near-misses only, never a wrong colour
      }
    }
  }
  // The NaN patches and the no-surface band really show the background in GL too.
  const Image<Rgb8> ssao = render_gl(with_colour, View::kSsao, style);
  EXPECT_EQ(ssao(15, 15), style.background);
  const Image<Rgb8> mvao = render_gl(with_colour, View::kMvao, style);
  EXPECT_EQ(mvao(35, 15), style.background);  // unobserved: no data in the mvao view
  EXPECT_EQ(mvao(155, 5), style.background);
  const Image<Rgb8> shaded = render_gl(with_colour, View::kShaded, style);
  EXPECT_EQ(shaded(155, 5), style.background);
  EXPECT_NE(shaded(35, 15), style.background);  // unobserved MVAO shades as open
  const Image<Rgb8> colour = render_gl(with_colour, View::kColour, style);
  EXPECT_EQ(colour(155, 5), style.background);
  EXPECT_EQ(colour(35, 15), with_colour.colour(35, 15));
}

TEST_F(GlTest, HalfResolutionModelImagesMatchTheCpuComposite) {
  // The pipeline publishes the model raycast (and its SSAO and MVAO) at half the frame's size.
  const ViewFrame frame = testing::model_at_fraction(testing::sphere_wall_frame(160, 120), 2);
  ViewStyle style;
  for (View view : kImageViews) {
    Image<Rgb8> cpu;
    composite_view(frame, view, cpu, style);
    const Image<Rgb8> gpu = render_gl(frame, view, style);
    const Comparison c = compare(cpu, gpu);
    std::printf("[ info ] %-11s (half) matching %.5f, max diff %d\n", view_name(view),
                c.matching_share, c.max_diff);
    EXPECT_GE(c.matching_share, kMinMatchingShare) << view_name(view);
    EXPECT_LE(c.max_diff, 8) << view_name(view);
  }
}

TEST_F(GlTest, ExactGreyAndNormalColours) {
  ViewFrame frame;
  frame.intrinsics.width = 8;
  frame.intrinsics.height = 4;
  frame.depth_m.resize(8, 4, 1.0f);
  frame.normals.resize(8, 4, Eigen::Vector3f(0, 0, -1));
  frame.mvao.resize(8, 4, 0.5f);
  ViewStyle style;
  style.to_light_camera = Eigen::Vector3f(0, 0, -1);
  const Image<Rgb8> shaded = render_gl(frame, View::kShaded, style);
  EXPECT_NEAR(shaded(3, 2).r, 128, 1);  // 127.5: either side is a correct rounding
  const Image<Rgb8> normals = render_gl(frame, View::kNormals, style);
  EXPECT_NEAR(normals(0, 0).r, 128, 1);
  EXPECT_NEAR(normals(0, 0).g, 128, 1);
  EXPECT_EQ(normals(0, 0).b, 255);
  // The mvao view: AO x 255 with no diffuse term, also under a slanted light.
  frame.mvao.fill(0.6f);
  ViewStyle slanted;
  const Image<Rgb8> mvao = render_gl(frame, View::kMvao, slanted);
  EXPECT_EQ(mvao(3, 2), (Rgb8{153, 153, 153}));
  // The colour views: the colour, and the colour x AO (0.6) per channel.
  frame.colour.resize(8, 4, Rgb8{200, 100, 40});
  EXPECT_EQ(render_gl(frame, View::kColour, slanted)(5, 1), (Rgb8{200, 100, 40}));
  EXPECT_EQ(render_gl(frame, View::kColourMvao, slanted)(5, 1), (Rgb8{120, 60, 24}));
}

TEST_F(GlTest, ReuploadsOfSameAndOtherSizesShowTheNewFrame) {
  const GlApi& gl = window_->gl();
  GlViewRenderer renderer;
  GlOffscreenTarget target;
  make_rig(renderer, target, 40, 30);
  if (HasFatalFailure()) return;
  const ViewStyle style;
  for (const auto& [w, h] : {std::pair{40, 30}, std::pair{40, 30}, std::pair{20, 10}}) {
    ViewFrame frame = testing::sphere_wall_frame(w, h);
    frame.ssao.fill(0.1f * static_cast<float>(w + h) / 70.0f);
    target.bind();
    gl.Viewport(0, 0, 40, 30);
    renderer.upload(frame);
    EXPECT_EQ(renderer.frame_width(), w);
    renderer.draw(View::kSsao, {0, 0, w, h}, style, OrbitCamera{});
    Image<Rgb8> gpu;
    target.read(gpu);
    // The view's rectangle is the bottom-left w x h of the target: image row h - 1 of the frame
    // is target row 29.
    EXPECT_EQ(gpu(0, 29), shade_ssao(frame.ssao(0, h - 1), style)) << w << "x" << h;
  }
}

TEST_F(GlTest, ViewOnlyUploadsShowTheNewFrameInThatView) {
  // The live view uploads the current view's data of each new frame: after a full upload of one
  // frame, a view-only upload of another shows the other in that view, whichever it is.
  const GlApi& gl = window_->gl();
  GlViewRenderer renderer;
  GlOffscreenTarget target;
  make_rig(renderer, target, 40, 30);
  if (HasFatalFailure()) return;
  const ViewStyle style;
  ViewFrame first = testing::sphere_wall_frame(40, 30);
  first.ssao.fill(0.2f);
  first.mvao.fill(0.2f);
  renderer.upload(first);
  for (View view : kImageViews) {
    ViewFrame second = testing::sphere_wall_frame(40, 30);
    second.ssao.fill(0.9f);
    second.mvao.fill(0.9f);
    second.colour.fill(Rgb8{10, 200, 90});
    for (int y = 0; y < 30; ++y)
      for (int x = 0; x < 20; ++x) second.raw_depth_m(x, y) = 0.0f;  // left half: no depth
    second.normals.fill(Eigen::Vector3f(0.6f, 0.0f, -0.8f));
    target.bind();
    gl.Viewport(0, 0, 40, 30);
    gl.ClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT);
    renderer.upload(second, view);
    renderer.draw(view, {0, 0, 40, 30}, style, OrbitCamera{});
    Image<Rgb8> gpu, cpu;
    target.read(gpu);
    composite_view(second, view, cpu, style);
    const Comparison c = compare(cpu, gpu);
    EXPECT_GE(c.matching_share, kMinMatchingShare) << view_name(view);
    renderer.upload(first);  // back to the first frame everywhere
  }
}

TEST_F(GlTest, ImageRowsAreNotFlipped) {
  ViewFrame frame;
  frame.intrinsics.width = 4;
  frame.intrinsics.height = 4;
  frame.ssao.resize(4, 4, 1.0f);
  frame.ssao(0, 0) = 0.0f;  // top-left black
  const Image<Rgb8> out = render_gl(frame, View::kSsao, ViewStyle{});
  EXPECT_EQ(out(0, 0), (Rgb8{0, 0, 0}));
  EXPECT_EQ(out(0, 3), (Rgb8{255, 255, 255}));
  EXPECT_EQ(out(3, 0), (Rgb8{255, 255, 255}));
}

TEST_F(GlTest, OrbitViewMatchesTheCpuSplatter) {
  ViewFrame frame;
  frame.intrinsics.width = 160;
  frame.intrinsics.height = 120;
  frame.surface = testing::sphere_points({0.2f, -0.1f, 2.0f}, 0.6f, 60);
  ViewStyle style;
  OrbitCamera orbit = fit_orbit(*frame.surface);
  orbit.yaw_rad = 0.4f;
  orbit.pitch_rad = 0.3f;
  Image<Rgb8> cpu(160, 120);
  composite_orbit(*frame.surface, orbit, cpu, style);
  const Image<Rgb8> gpu = render_gl(frame, View::kOrbit, style, orbit);
  const Comparison c = compare(cpu, gpu);
  std::printf("[ info ] orbit    matching %.5f, max diff %d\n", c.matching_share, c.max_diff);
  // Points whose square edge falls within float rounding of a pixel centre may cover one pixel
  // more or less in GL, and near-equal depths may resolve the other way: 99 % of the pixels.
  EXPECT_GE(c.matching_share, 0.99);
  std::size_t covered = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) covered += gpu(x, y) != style.background;
  EXPECT_GT(covered, 2000u);
}

/// Two face-less 40 x 40 grids of points 2 cm apart facing -z: at z = 2 m with AO alternating
/// 0.1 and 1.0 from point to point (a checkerboard: every blended pixel depends on the Gaussian
/// weights), and, 10 cm behind it and 40 cm to the right, one with AO 0.5 (hidden where the first
/// covers it, more than a splat radius behind).
std::shared_ptr<TriangleMesh> checker_and_plane_behind() {
  auto mesh = std::make_shared<TriangleMesh>();
  for (int plane = 0; plane < 2; ++plane)
    for (int i = 0; i < 40; ++i)
      for (int j = 0; j < 40; ++j) {
        mesh->vertices.push_back(
            {-0.4f + 0.02f * i + 0.4f * plane, -0.4f + 0.02f * j, 2.0f + 0.1f * plane});
        mesh->normals.push_back({0.0f, 0.0f, -1.0f});
        mesh->quality.push_back(plane == 1 ? 0.5f : (i + j) % 2 == 0 ? 0.1f : 1.0f);
      }
  return mesh;
}

TEST_F(GlTest, SplatsViewMatchesTheCpuComposite) {
  // Face-less clouds (the style's spacing) and a mesh (its mean edge length), from an angle.
  ViewStyle sphere_style;
  sphere_style.splat_spacing_m = 0.03f;  // the sphere's points are about 3 cm apart
  ViewStyle checker_style;
  checker_style.splat_spacing_m = 0.02f;
  struct Case {
    std::shared_ptr<TriangleMesh> surface;
    ViewStyle style;
    bool sphere;
  };
  const Case cases[] = {{testing::sphere_points({0.2f, -0.1f, 2.0f}, 0.6f, 60), sphere_style, true},
                        {testing::sphere_mesh({0.2f, -0.1f, 2.0f}, 0.6f, 40), ViewStyle{}, true},
                        {checker_and_plane_behind(), checker_style, false}};
  for (const auto& [surface, style, sphere] : cases) {
    ViewFrame frame;
    frame.intrinsics.width = 160;
    frame.intrinsics.height = 120;
    frame.surface = surface;
    OrbitCamera orbit = fit_orbit(*frame.surface);
    orbit.yaw_rad = 0.4f;
    orbit.pitch_rad = 0.3f;
    Image<Rgb8> cpu(160, 120);
    composite_splats(*frame.surface, orbit, cpu, style);
    for (const bool view_only : {false, true}) {
      const Image<Rgb8> gpu = render_gl(frame, View::kSplats, style, orbit, view_only);
      const Comparison c = compare(cpu, gpu);
      std::printf("[ info ] splats (%zu points%s)%s matching %.5f, max diff %d\n",
                  surface->vertices.size(), surface->faces.empty() ? "" : ", faces",
                  view_only ? " (its data only)" : "", c.matching_share, c.max_diff);
      EXPECT_GE(c.matching_share, kMinMatchingShare);
    }
    if (!sphere) continue;
    // The sphere is a disk about 55 pixels across (2 400 pixels); the splats leave no holes in a
    // 30 x 30 square around its centre.
    std::size_t covered = 0;
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 160; ++x) covered += cpu(x, y) != style.background;
    EXPECT_GT(covered, 2400u);
    const Eigen::Vector4f c =
        orbit_clip_from_world(orbit, 160.0f / 120.0f) * Eigen::Vector4f(0.2f, -0.1f, 2.0f, 1.0f);
    const int cx = static_cast<int>((c.x() / c.w() * 0.5f + 0.5f) * 160.0f);
    const int cy = 119 - static_cast<int>((c.y() / c.w() * 0.5f + 0.5f) * 120.0f);
    for (int y = cy - 15; y < cy + 15; ++y)
      for (int x = cx - 15; x < cx + 15; ++x)
        EXPECT_NE(cpu(x, y), style.background) << x << "," << y;
  }
}

TEST_F(GlTest, SplatsViewDrawsIntoItsRectangle) {
  // Into the middle of a larger target (the sums are read at the rectangle's origin), twice (the
  // float target is reused), the second time in a smaller rectangle (and resized).
  ViewFrame frame;
  frame.intrinsics.width = 160;
  frame.intrinsics.height = 120;
  frame.surface = testing::sphere_mesh({0.0f, 0.0f, 2.0f}, 0.5f, 30);
  const ViewStyle style;
  const GlApi& gl = window_->gl();
  GlViewRenderer renderer;
  GlOffscreenTarget target;
  make_rig(renderer, target, 200, 150);
  if (HasFatalFailure()) return;
  renderer.upload(frame);
  for (const GlRect rect :
       {GlRect{30, 20, 160, 120}, GlRect{30, 20, 160, 120}, GlRect{10, 40, 80, 60}}) {
    target.bind();
    gl.Viewport(0, 0, 200, 150);
    gl.ClearColor(1.0f, 0.0f, 0.0f, 1.0f);
    gl.Clear(GL_COLOR_BUFFER_BIT);
    const OrbitCamera orbit = fit_orbit(*frame.surface);
    renderer.draw(View::kSplats, rect, style, orbit);
    Image<Rgb8> gpu;
    target.read(gpu);
    EXPECT_EQ(gl.GetError(), static_cast<GLenum>(GL_NO_ERROR));
    Image<Rgb8> cpu(rect.width, rect.height);
    composite_splats(*frame.surface, orbit, cpu, style);
    Image<Rgb8> inside(rect.width, rect.height);  // the rectangle of the target (rows go down)
    for (int y = 0; y < rect.height; ++y)
      for (int x = 0; x < rect.width; ++x)
        inside(x, y) = gpu(rect.x + x, 150 - rect.y - rect.height + y);
    const Comparison c = compare(cpu, inside);
    EXPECT_GE(c.matching_share, kMinMatchingShare) << rect.width;
    EXPECT_EQ(gpu(rect.x - 1, 75), (Rgb8{255, 0, 0}));  // left of the rectangle: untouched
    EXPECT_EQ(gpu(199, 0), (Rgb8{255, 0, 0}));
  }
}

TEST_F(GlTest, HudOverlayMatchesTheCpuBlend) {
  const ViewFrame frame = testing::sphere_wall_frame(320, 160);
  Image<Rgba8> hud;
  render_text_overlay(hud_lines(&frame, View::kShaded, 60.0), 1, hud);
  ASSERT_LE(hud.width(), 320 - 3);
  ASSERT_LE(hud.height(), 160 - 2);
  ViewStyle style;
  Image<Rgb8> cpu;
  composite_view(frame, View::kDepth, cpu, style);
  blend_overlay(hud, 3, 2, cpu);

  const GlApi& gl = window_->gl();
  std::string error;
  GlViewRenderer renderer;
  ASSERT_TRUE(renderer.init(gl, error)) << error;
  GlOffscreenTarget target;
  ASSERT_TRUE(target.create(gl, 320, 160, error)) << error;
  target.bind();
  renderer.upload(frame);
  renderer.draw(View::kDepth, {0, 0, 320, 160}, style, OrbitCamera{});
  renderer.draw_overlay(hud, 3, 2, 160);
  Image<Rgb8> gpu;
  target.read(gpu);
  const Comparison c = compare(cpu, gpu);
  EXPECT_GE(c.matching_share, kMinMatchingShare);
  EXPECT_LE(c.max_diff, 8);
}

TEST_F(GlTest, ShaderCompileFailureIsOneLineNamingTheFile) {
  std::string error;
  GlViewRenderer renderer;
  EXPECT_FALSE(renderer.init(window_->gl(), error,
                             {{"normals.frag", "#version 330 core\nvoid main() { oops; }\n"}}));
  EXPECT_NE(error.find("normals.frag"), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
  // A program that compiles but cannot link (no main in the fragment stage).
  error.clear();
  EXPECT_FALSE(renderer.init(window_->gl(), error, {{"ssao.frag", "#version 330 core\n"}}));
  EXPECT_NE(error.find("ssao"), std::string::npos) << error;
  // And the renderer is usable again after a good init.
  EXPECT_TRUE(renderer.init(window_->gl(), error)) << error;
}

/// The live view on this display: runs a few redraws, quits, falls back.
class LiveViewTest : public GlTest {
 protected:
  void SetUp() override {
    GlTest::SetUp();
    window_.reset();  // the live view makes its own window (one GLFW user at a time)
  }
  /// Live view options with a hidden 320 x 240 window.
  static LiveViewOptions hidden_window() {
    LiveViewOptions options;
    options.window.visible = false;
    options.window.width = 320;
    options.window.height = 240;
    return options;
  }
};

TEST_F(LiveViewTest, RedrawsTheFeedUntilStopped) {
  auto frame = std::make_shared<ViewFrame>(testing::sphere_wall_frame(64, 48));
  frame->surface = testing::sphere_points({0, 0, 2}, 0.5f, 20);
  std::shared_ptr<const ViewFrame> published = frame;
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  LiveViewOptions options = hidden_window();
  options.max_redraw_hz = 0;  // no waiting between redraws
  options.idle_redraw_s = 0;  // and a redraw on every pass, though the frame stays the same
  options.max_redraws = 5;
  for (int v = 0; v < kViewCount; ++v) {
    options.initial_view = static_cast<View>(v);
    const LiveViewResult r = run_view(
        options, [&] { return published; }, commands, stop);
    EXPECT_EQ(r.outcome, LiveViewResult::Outcome::kStopped) << r.message;
    EXPECT_EQ(r.redraws, 5);
  }
  EXPECT_FALSE(commands.poll());

  // Stopped from another thread (the pipeline's stop), on a thread of its own.
  options.max_redraws = 0;
  options.max_redraw_hz = 200;
  LiveViewResult result;
  std::atomic<int> feed_calls{0};  // one per loop iteration, after the window and shaders are up
  std::atomic<bool> finished{false};
  std::thread render([&] {
    result = run_view(
        options,
        [&] {
          ++feed_calls;
          return published;
        },
        commands, stop);
    finished = true;
  });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (feed_calls.load() < 3 && !finished.load() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  stop = true;
  render.join();
  EXPECT_EQ(result.outcome, LiveViewResult::Outcome::kStopped) << result.message;
  EXPECT_GT(result.redraws, 0);
}

TEST_F(LiveViewTest, RedrawsOnlyForNewFrames) {
  auto first = std::make_shared<ViewFrame>(testing::sphere_wall_frame(64, 48));
  auto second = std::make_shared<ViewFrame>(*first);
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  LiveViewOptions options = hidden_window();
  options.max_redraw_hz = 500;
  options.idle_redraw_s = 60;  // longer than the test
  // 40 passes with the first frame, 40 with the second, then stop: one redraw for each frame
  // (and one more if the window manager reports damage, e.g. the first expose).
  int calls = 0;
  const LiveViewResult r = run_view(
      options,
      [&]() -> std::shared_ptr<const ViewFrame> {
        ++calls;
        if (calls >= 80) stop = true;
        return calls <= 40 ? first : second;
      },
      commands, stop);
  EXPECT_EQ(r.outcome, LiveViewResult::Outcome::kStopped) << r.message;
  EXPECT_GE(calls, 80);
  EXPECT_GE(r.redraws, 2);
  EXPECT_LE(r.redraws, 3);
}

TEST_F(LiveViewTest, SoftwareRendererTakesNewFramesAtMostAtTheCap) {
  // A feed with a new frame on every call, for 1.2 s. With a software renderer (Mesa's llvmpipe
  // under Xvfb, as in CI) and a 5 Hz cap, about 6 frames are taken; without the cap, every pass
  // of a 200 Hz loop takes one. A GPU renderer is not capped.
  const auto base = std::make_shared<ViewFrame>(testing::sphere_wall_frame(64, 48));
  for (const double cap : {5.0, 0.0}) {
    ViewCommandQueue commands;
    std::atomic<bool> stop{false};
    LiveViewOptions options = hidden_window();
    options.max_redraw_hz = 200;
    options.idle_redraw_s = 60;
    options.software_max_frame_hz = cap;
    int taken = 0;
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(1200);
    const LiveViewResult r = run_view(
        options,
        [&]() -> std::shared_ptr<const ViewFrame> {
          if (std::chrono::steady_clock::now() > end) stop = true;
          ++taken;
          return std::make_shared<ViewFrame>(*base);
        },
        commands, stop);
    ASSERT_EQ(r.outcome, LiveViewResult::Outcome::kStopped) << r.message;
    if (!software_renderer(r.gl_renderer)) GTEST_SKIP() << "hardware GL: " << r.gl_renderer;
    if (cap > 0) {
      EXPECT_GE(taken, 3) << cap;
      EXPECT_LE(taken, 8) << cap;  // 1.2 s at 5 Hz, and the first frame at once
    } else {
      EXPECT_GT(taken, 20);
    }
  }
}

TEST(LiveView, SoftwareRenderersAreRecognised) {
  EXPECT_TRUE(software_renderer("llvmpipe (LLVM 15.0.6, 256 bits)"));
  EXPECT_TRUE(software_renderer("softpipe"));
  EXPECT_TRUE(software_renderer("Google SwiftShader"));
  EXPECT_FALSE(software_renderer("Mesa Intel(R) UHD Graphics 620 (KBL GT2)"));
  EXPECT_FALSE(software_renderer("NVIDIA GeForce RTX 3060/PCIe/SSE2"));
  EXPECT_FALSE(software_renderer(""));
}

TEST_F(LiveViewTest, BrokenShaderFallsBackHeadless) {
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  LiveViewOptions options;
  options.window.visible = false;
  options.shader_overrides = {{"shaded.frag", "not glsl"}};
  const auto start = std::chrono::steady_clock::now();
  const LiveViewResult r = run_view(options, nullptr, commands, stop);
  EXPECT_EQ(r.outcome, LiveViewResult::Outcome::kUnavailable);
  EXPECT_NE(r.message.find("shaded.frag"), std::string::npos) << r.message;
  EXPECT_EQ(r.message.find('\n'), std::string::npos);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  EXPECT_FALSE(commands.quit_requested());  // falling back is not quitting
}

/// True when a libGL / libGLX / libEGL / libOpenGL is mapped into this process.
bool gl_library_loaded() {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line))
    for (const char* lib : {"/libGL.so", "/libGLX.so", "/libGLX_mesa", "/libEGL", "/libOpenGL"})
      if (line.find(lib) != std::string::npos) return true;
  return false;
}

TEST(LiveViewNoDisplay, NothingLinksLibGl) {
  aoscan::testing::ScratchDir scratch;
  // GL functions come through glfwGetProcAddress, so no binary needs libGL at load time: a
  // headless run never maps it. (The test binary uses every render function, GLFW included.)
  const std::string out = scratch.file("ldd.txt");
  const std::string cmd = "ldd /proc/" + std::to_string(::getpid()) + "/exe > " + out + " 2>&1";
  if (std::system(cmd.c_str()) != 0) GTEST_SKIP() << "ldd is not available";
  std::ifstream in(out);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("libglfw"), std::string::npos) << text;
  // libGLX.so.0, GLVND's GLX dispatch, is mapped by Debian's OpenCV core (built with OpenGL
  // interop), which the colour images of io use: it loads no GL implementation and opens no
  // display until a GLX function is called, so it is not checked here.
  for (const char* lib : {"libGL.so", "libOpenGL.so", "libEGL.so"})
    EXPECT_EQ(text.find(lib), std::string::npos) << lib << " linked:\n" << text;
}

TEST(LiveViewNoDisplay, FallsBackHeadlessWithoutTouchingGl) {
  const bool gl_before = gl_library_loaded();
  const char* old = std::getenv("DISPLAY");
  const std::string saved = old ? old : "";
  ::unsetenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  const std::string saved_wayland = wayland ? wayland : "";
  ::unsetenv("WAYLAND_DISPLAY");
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  const LiveViewResult r = run_live_view(LiveViewOptions{}, nullptr, commands, stop);
  if (old) ::setenv("DISPLAY", saved.c_str(), 1);
  if (wayland) ::setenv("WAYLAND_DISPLAY", saved_wayland.c_str(), 1);
  EXPECT_EQ(r.outcome, LiveViewResult::Outcome::kUnavailable);
  EXPECT_NE(r.message.find("no display"), std::string::npos) << r.message;
  EXPECT_TRUE(r.gl_renderer.empty());
  if (!gl_before) {
    EXPECT_FALSE(gl_library_loaded()) << "the fall-back loaded a GL library";
  }
}

TEST(LiveViewNoDisplay, UnreachableDisplayFallsBack) {
  const char* old = std::getenv("DISPLAY");
  const std::string saved = old ? old : "";
  ::setenv("DISPLAY", ":12345", 1);  // no X server there
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  const LiveViewResult r = run_live_view(LiveViewOptions{}, nullptr, commands, stop);
  if (old) {
    ::setenv("DISPLAY", saved.c_str(), 1);
  } else {
    ::unsetenv("DISPLAY");
  }
  EXPECT_EQ(r.outcome, LiveViewResult::Outcome::kUnavailable);
  EXPECT_NE(r.message.find("GLFW"), std::string::npos) << r.message;
}

TEST(LiveViewDisplayLoss, ServerEndingMidRunEndsTheViewNotTheProcess) {
  // Without our X I/O error handlers Xlib would call exit() inside the window thread here.
  testing::PrivateXvfb x;
  if (!x.running()) GTEST_SKIP() << "no private display: " << x.error();
  const char* old = std::getenv("DISPLAY");
  const std::string saved = old ? old : "";
  ::setenv("DISPLAY", x.display().c_str(), 1);  // read only before the window exists
  {
    // As GlTest does: Mesa's libraries stay mapped after glfwTerminate() (LeakSanitizer).
    std::string error;
    WindowOptions hidden;
    hidden.visible = false;
    const std::unique_ptr<GlWindow> pin_window = create_window(hidden, error);
    if (pin_window) pin_loaded_libraries();
  }
  auto frame = std::make_shared<ViewFrame>(testing::sphere_wall_frame(64, 48));
  std::shared_ptr<const ViewFrame> published = frame;
  ViewCommandQueue commands;
  std::atomic<bool> stop{false};
  LiveViewOptions options;
  options.window.width = 320;
  options.window.height = 240;
  options.max_redraw_hz = 100;
  LiveViewResult result;
  std::atomic<int> feed_calls{0};
  std::atomic<bool> finished{false};
  std::thread render([&] {
    result = run_live_view(
        options,
        [&] {
          ++feed_calls;
          return published;
        },
        commands, stop);
    finished = true;
  });
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (feed_calls.load() < 3 && !finished.load() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool was_drawing = feed_calls.load() >= 3 && !finished.load();
  x.stop();  // while the view redraws
  deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!finished.load() && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const bool ended_by_itself = finished.load();
  stop = true;  // (only if it did not end by itself)
  render.join();
  if (old) {
    ::setenv("DISPLAY", saved.c_str(), 1);
  } else {
    ::unsetenv("DISPLAY");
  }
  if (!was_drawing && result.outcome == LiveViewResult::Outcome::kUnavailable)
    GTEST_SKIP() << "no GL 3.3 on the private Xvfb: " << result.message;
  ASSERT_TRUE(was_drawing) << result.message;
  EXPECT_TRUE(ended_by_itself) << "the view kept running on a dead display";
  EXPECT_EQ(result.outcome, LiveViewResult::Outcome::kDisplayLost) << result.message;
  EXPECT_EQ(result.message, "the display " + x.display() + " closed");
  EXPECT_GT(result.redraws, 0);
  EXPECT_FALSE(commands.poll()) << "losing the display is not a quit";
  EXPECT_FALSE(commands.quit_requested());

  // GLFW was shut down cleanly: a window opens again on the original display, when there is one.
  if (old && *old) {
    std::string error;
    WindowOptions hidden;
    hidden.visible = false;
    std::unique_ptr<GlWindow> again = create_window(hidden, error);
    if (again) {
      EXPECT_FALSE(again->display_lost());
      EXPECT_FALSE(again->poll_events(0.0).display_lost);
    }
  }
}

TEST(Letterbox, KeepsAspectCentred) {
  const GlRect wide = letterbox(640, 480, 1280, 720);
  EXPECT_EQ(wide.width, 960);
  EXPECT_EQ(wide.height, 720);
  EXPECT_EQ(wide.x, 160);
  EXPECT_EQ(wide.y, 0);
  const GlRect tall = letterbox(640, 480, 640, 1000);
  EXPECT_EQ(tall.width, 640);
  EXPECT_EQ(tall.height, 480);
  EXPECT_EQ(tall.y, 260);
  EXPECT_EQ(letterbox(0, 480, 100, 100).width, 0);
}

}  // namespace
}  // namespace aoscan
