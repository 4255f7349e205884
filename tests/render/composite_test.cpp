/// @file composite_test.cpp
/// @brief Exact answers of the CPU composite (the GL reference): grey levels, normal colours,
/// colour-map stops, no-data pixels, the orbit splatter, the Gaussian splats and the RGB PNG
/// writer.
#include "render/composite.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "core/status.h"
#include "io/colour_image.h"
#include "render/render_test_util.h"
#include "support/scratch_dir.h"

namespace aoscan {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// A 4x2 frame: every pixel a camera-facing plane at 1 m.
ViewFrame plane_frame(float ao) {
  ViewFrame f;
  f.intrinsics.width = 4;
  f.intrinsics.height = 2;
  f.depth_m.resize(4, 2, 1.0f);
  f.normals.resize(4, 2, Eigen::Vector3f(0, 0, -1));
  f.ssao.resize(4, 2, ao);
  f.mvao.resize(4, 2, ao);
  return f;
}

ViewStyle head_on_light() {
  ViewStyle s;
  s.to_light_camera = Eigen::Vector3f(0, 0, -1);
  return s;
}

TEST(Composite, ToU8RoundsAndClamps) {
  EXPECT_EQ(to_u8(0.0f), 0);
  EXPECT_EQ(to_u8(0.5f), 128);  // 127.5 rounds up
  EXPECT_EQ(to_u8(1.0f), 255);
  EXPECT_EQ(to_u8(-3.0f), 0);
  EXPECT_EQ(to_u8(7.0f), 255);
  EXPECT_EQ(to_u8(kNaN), 0);
  EXPECT_EQ(to_u8(100.0f / 255.0f), 100);
}

TEST(Composite, ShadedIsAoTimesDiffuse) {
  const ViewStyle style = head_on_light();
  Image<Rgb8> out;
  composite_view(plane_frame(0.5f), View::kShaded, out, style);
  ASSERT_EQ(out.width(), 4);
  ASSERT_EQ(out.height(), 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(out(x, y), (Rgb8{128, 128, 128}));
  // A normal at 60 degrees to the light: diffuse = ambient + (1 - ambient) * 0.5.
  const Eigen::Vector3f n60(std::sin(1.0471976f), 0.0f, -std::cos(1.0471976f));
  EXPECT_EQ(shade_mvao(1.0f, n60, 1.0f, style).r, to_u8(0.25f + 0.75f * 0.5f));
  // Facing away: only the ambient term, scaled by AO.
  EXPECT_EQ(shade_mvao(1.0f, {0, 0, 1}, 0.8f, style).g, to_u8(0.8f * 0.25f));
  // Unobserved (NaN, negative) AO shades as open; AO above 1 is clamped.
  EXPECT_EQ(shade_mvao(1.0f, {0, 0, -1}, kNaN, style).b, 255);
  EXPECT_EQ(shade_mvao(1.0f, {0, 0, -1}, -1.0f, style).b, 255);
  EXPECT_EQ(shade_mvao(1.0f, {0, 0, -1}, 1.5f, style).b, 255);
  // No surface: zero depth or zero normal.
  EXPECT_EQ(shade_mvao(0.0f, {0, 0, -1}, 0.5f, style), style.background);
  EXPECT_EQ(shade_mvao(1.0f, {0, 0, 0}, 0.5f, style), style.background);
}

TEST(Composite, SsaoIsGrey) {
  const ViewStyle style;
  Image<Rgb8> out;
  composite_view(plane_frame(0.25f), View::kSsao, out, style);
  EXPECT_EQ(out(3, 1), (Rgb8{64, 64, 64}));
  EXPECT_EQ(shade_ssao(kNaN, style), style.background);
  EXPECT_EQ(shade_ssao(-0.1f, style), style.background);
  EXPECT_EQ(shade_ssao(2.0f, style), (Rgb8{255, 255, 255}));
}

TEST(Composite, MvaoViewIsTheGridsAoAsGreyWithoutDiffuse) {
  ViewStyle style;  // the default light: a diffuse term would darken these pixels
  const ViewFrame f = testing::sphere_wall_frame(160, 120);
  Image<Rgb8> out;
  composite_view(f, View::kMvao, out, style);
  ASSERT_EQ(out.width(), 160);
  int grey_pixels = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const float ao = f.mvao(x, y);
      if (std::isnan(ao) || !(f.depth_m(x, y) > 0.0f)) {
        EXPECT_EQ(out(x, y), style.background) << x << "," << y;  // unobserved, no surface
        continue;
      }
      // round(AO x 255): within half a level (either side of an exact tie), and grey.
      const Rgb8 p = out(x, y);
      ASSERT_TRUE(p.r == p.g && p.g == p.b) << x << "," << y;
      ASSERT_LE(std::abs(p.r - ao * 255.0), 0.5 + 1e-4) << x << "," << y << " ao " << ao;
      ++grey_pixels;
    }
  EXPECT_GE(grey_pixels, 150 * 120 - 100);  // all but the no-surface band and the NaN patch
  // Given values: AO x 255 rounded, clamped; NaN and negative are no data, as is no surface.
  const Eigen::Vector3f n(0.6f, 0.0f, -0.8f);
  EXPECT_EQ(shade_mvao_grey(1.0f, n, 0.25f, style), (Rgb8{64, 64, 64}));
  EXPECT_EQ(shade_mvao_grey(1.0f, n, 0.6f, style), (Rgb8{153, 153, 153}));
  EXPECT_EQ(shade_mvao_grey(1.0f, n, 1.0f, style), (Rgb8{255, 255, 255}));
  EXPECT_EQ(shade_mvao_grey(1.0f, n, 1.2f, style), (Rgb8{255, 255, 255}));
  EXPECT_EQ(shade_mvao_grey(1.0f, n, kNaN, style), style.background);
  EXPECT_EQ(shade_mvao_grey(1.0f, n, -1.0f, style), style.background);
  EXPECT_EQ(shade_mvao_grey(0.0f, n, 0.5f, style), style.background);
  EXPECT_EQ(shade_mvao_grey(1.0f, {0, 0, 0}, 0.5f, style), style.background);
  // A frame whose MVAO image was not built shows no data everywhere.
  ViewFrame no_mvao = f;
  no_mvao.mvao = Image<float>();
  composite_view(no_mvao, View::kMvao, out, style);
  EXPECT_EQ(out(80, 60), style.background);
}

TEST(Composite, ColourViewIsTheFusedColour) {
  const ViewStyle style;
  ViewFrame f = testing::sphere_wall_frame(160, 120);
  Image<Rgb8> out;
  composite_view(f, View::kColour, out, style);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      const bool surface = f.depth_m(x, y) > 0.0f;
      ASSERT_EQ(out(x, y), surface ? f.colour(x, y) : style.background) << x << "," << y;
    }
  EXPECT_EQ(shade_colour(1.0f, {0, 0, -1}, Rgb8{200, 100, 40}, style), (Rgb8{200, 100, 40}));
  EXPECT_EQ(shade_colour(0.0f, {0, 0, -1}, Rgb8{200, 100, 40}, style), style.background);
  EXPECT_EQ(shade_colour(1.0f, {0, 0, 0}, Rgb8{200, 100, 40}, style), style.background);
}

TEST(Composite, ColourMvaoIsColourTimesAoPerChannel) {
  ViewStyle style;  // the default light: no diffuse term may show
  ViewFrame f = testing::sphere_wall_frame(160, 120);
  Image<Rgb8> out;
  composite_view(f, View::kColourMvao, out, style);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) {
      if (!(f.depth_m(x, y) > 0.0f)) {
        ASSERT_EQ(out(x, y), style.background);
        continue;
      }
      const Rgb8 c = f.colour(x, y);
      const float ao = std::isnan(f.mvao(x, y)) ? 1.0f : f.mvao(x, y);  // unobserved: open
      const Rgb8 expected{to_u8(c.r / 255.0f * ao), to_u8(c.g / 255.0f * ao),
                          to_u8(c.b / 255.0f * ao)};
      ASSERT_EQ(out(x, y), expected) << x << "," << y;
    }
  // Given values.
  const Rgb8 c{200, 100, 40};
  EXPECT_EQ(shade_colour_mvao(1.0f, {0, 0, -1}, c, 0.5f, style), (Rgb8{100, 50, 20}));
  EXPECT_EQ(shade_colour_mvao(1.0f, {0, 0, -1}, c, 0.25f, style), (Rgb8{50, 25, 10}));
  EXPECT_EQ(shade_colour_mvao(1.0f, {1, 0, 0}, c, 0.25f, style), (Rgb8{50, 25, 10}));  // no diffuse
  EXPECT_EQ(shade_colour_mvao(1.0f, {0, 0, -1}, c, kNaN, style), c);   // unobserved: open
  EXPECT_EQ(shade_colour_mvao(1.0f, {0, 0, -1}, c, 1.5f, style), c);   // clamped
  EXPECT_EQ(shade_colour_mvao(0.0f, {0, 0, -1}, c, 0.5f, style), style.background);
}

TEST(Composite, ColourViewsWithoutColourShowTheShadedView) {
  const ViewStyle style;
  ViewFrame f = testing::sphere_wall_frame(160, 120);
  Image<Rgb8> shaded;
  composite_view(f, View::kShaded, shaded, style);
  ViewFrame wrong_size = f;
  wrong_size.colour.resize(80, 40);
  f.colour = Image<Rgb8>();  // a run without colour
  for (const ViewFrame* frame : {&f, &wrong_size})
    for (View v : {View::kColour, View::kColourMvao}) {
      Image<Rgb8> out;
      composite_view(*frame, v, out, style);
      EXPECT_EQ(out, shaded) << view_name(v);
    }
}

TEST(Composite, NormalColours) {
  const ViewStyle style;
  EXPECT_EQ(shade_normal(1.0f, {0, 0, -1}, style), (Rgb8{128, 128, 255}));  // facing the camera
  EXPECT_EQ(shade_normal(1.0f, {1, 0, 0}, style), (Rgb8{255, 128, 128}));   // right
  EXPECT_EQ(shade_normal(1.0f, {0, -1, 0}, style), (Rgb8{128, 255, 128}));  // up (y is down)
  EXPECT_EQ(shade_normal(0.0f, {0, 0, -1}, style), style.background);
}

TEST(Composite, DepthColourMapStops) {
  ViewStyle style;
  style.depth_min_m = 1.0f;
  style.depth_max_m = 5.0f;  // stops at 1, 2, 3, 4, 5 m
  EXPECT_EQ(shade_depth(1.0f, style), (Rgb8{26, 26, 153}));
  EXPECT_EQ(shade_depth(0.5f, style), (Rgb8{26, 26, 153}));  // clamped below
  EXPECT_EQ(shade_depth(2.0f, style), (Rgb8{0, 179, 230}));
  EXPECT_EQ(shade_depth(3.0f, style), (Rgb8{51, 204, 51}));
  EXPECT_EQ(shade_depth(4.0f, style), (Rgb8{242, 217, 26}));
  EXPECT_EQ(shade_depth(5.0f, style), (Rgb8{204, 26, 26}));
  EXPECT_EQ(shade_depth(9.0f, style), (Rgb8{204, 26, 26}));  // clamped above
  const Rgb8 half = shade_depth(1.5f, style);                // halfway between stops 0 and 1
  EXPECT_EQ(half.r, 13);
  EXPECT_NEAR(half.g, 102.5, 0.5);
  EXPECT_NEAR(half.b, 191.5, 0.5);
  EXPECT_EQ(shade_depth(0.0f, style), style.background);
  EXPECT_EQ(shade_depth(kNaN, style), style.background);
}

TEST(Composite, DepthViewPrefersRawDepth) {
  ViewFrame f = plane_frame(0.5f);
  ViewStyle style;
  Image<Rgb8> out;
  composite_view(f, View::kDepth, out, style);
  EXPECT_EQ(out(0, 0), shade_depth(1.0f, style));  // no raw depth: the raycast
  f.raw_depth_m.resize(4, 2, 3.0f);
  f.raw_depth_m(1, 0) = 0.0f;
  composite_view(f, View::kDepth, out, style);
  EXPECT_EQ(out(0, 0), shade_depth(3.0f, style));
  EXPECT_EQ(out(1, 0), style.background);
}

TEST(Composite, MissingOrMismatchedImagesAreNoData) {
  ViewFrame f;
  f.intrinsics.width = 3;
  f.intrinsics.height = 3;
  f.depth_m.resize(2, 2, 1.0f);  // wrong size
  const ViewStyle style;
  Image<Rgb8> out;
  for (int i = 0; i < kViewCount; ++i) {
    const View v = static_cast<View>(i);
    composite_view(f, v, out, style);
    ASSERT_EQ(out.width(), 3) << view_name(v);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x) EXPECT_EQ(out(x, y), style.background) << view_name(v);
  }
}

TEST(Composite, FractionalResolutionImagesAreEnlargedByReplication) {
  const ViewStyle style;
  for (int scale : {2, 4}) {
    const ViewFrame small = testing::model_at_fraction(testing::sphere_wall_frame(160, 120), scale);
    const ViewFrame full = testing::model_replicated(small);
    ASSERT_EQ(full.depth_m.width(), 160);
    for (View v : {View::kShaded, View::kSsao, View::kMvao, View::kColour, View::kColourMvao,
                   View::kNormals, View::kDepth}) {
      Image<Rgb8> a, b;
      composite_view(small, v, a, style);
      composite_view(full, v, b, style);
      ASSERT_EQ(a.width(), 160);
      ASSERT_EQ(a.height(), 120);
      int differ = 0;
      for (int y = 0; y < 120; ++y)
        for (int x = 0; x < 160; ++x) differ += a(x, y) != b(x, y);
      EXPECT_EQ(differ, 0) << view_name(v) << " at 1/" << scale;
    }
  }
  // An MVAO image of another size than the depth's is no data (shaded as open), not misread.
  ViewFrame odd = testing::model_at_fraction(testing::sphere_wall_frame(160, 120), 2);
  ViewFrame no_mvao = odd;
  no_mvao.mvao = Image<float>();
  odd.mvao.resize(160, 120, 0.0f);  // full size, while the depth is half
  Image<Rgb8> a, b;
  composite_view(odd, View::kShaded, a, style);
  composite_view(no_mvao, View::kShaded, b, style);
  EXPECT_EQ(a(80, 60), b(80, 60));
  EXPECT_NE(a(80, 60), style.background);
}

TEST(Composite, ImageScale) {
  EXPECT_EQ(image_scale(Image<float>(640, 480), 640, 480), 1);
  EXPECT_EQ(image_scale(Image<float>(320, 240), 640, 480), 2);
  EXPECT_EQ(image_scale(Image<float>(160, 120), 640, 480), 4);
  EXPECT_EQ(image_scale(Image<float>(320, 480), 640, 480), 0);
  EXPECT_EQ(image_scale(Image<float>(300, 225), 640, 480), 0);
  EXPECT_EQ(image_scale(Image<float>(1280, 960), 640, 480), 0);
  EXPECT_EQ(image_scale(Image<float>(), 640, 480), 0);
}

TEST(Composite, ViewCycle) {
  View v = View::kShaded;
  const char* expected[] = {"ssao",  "mvao",  "colour", "colour_mvao", "normals",
                            "depth", "orbit", "splats", "shaded"};
  for (const char* name : expected) {
    v = next_view(v);
    EXPECT_STREQ(view_name(v), name);
  }
}

TEST(Orbit, FitFramesTheBoundingBox) {
  TriangleMesh mesh;
  mesh.vertices = {{-1, 0, 2}, {1, 2, 4}};
  const OrbitCamera camera = fit_orbit(mesh);
  EXPECT_TRUE(camera.target_world.isApprox(Eigen::Vector3f(0, 1, 3)));
  const float radius = 0.5f * std::sqrt(12.0f);
  EXPECT_NEAR(camera.distance_m, 1.1f * radius / std::sin(0.5f * camera.fov_y_rad), 1e-5f);
  // Every vertex is inside the view.
  const Eigen::Matrix4f m = orbit_clip_from_world(camera, 1.0f);
  for (const auto& v : mesh.vertices) {
    const Eigen::Vector4f c = m * v.homogeneous();
    EXPECT_LT(std::abs(c.x()), c.w());
    EXPECT_LT(std::abs(c.y()), c.w());
  }
}

TEST(Orbit, ZeroAnglesLookAlongPlusZWithWorldYDown) {
  OrbitCamera camera;
  camera.target_world = {0, 0, 5};
  camera.distance_m = 5;  // the eye at the origin, like the first camera
  const Eigen::Matrix4f m = orbit_clip_from_world(camera, 1.0f);
  const Eigen::Vector4f ahead = m * Eigen::Vector4f(0, 0, 5, 1);
  EXPECT_NEAR(ahead.x() / ahead.w(), 0.0f, 1e-6f);
  EXPECT_NEAR(ahead.y() / ahead.w(), 0.0f, 1e-6f);
  const Eigen::Vector4f below = m * Eigen::Vector4f(0, 1, 5, 1);  // world +y is down
  EXPECT_LT(below.y() / below.w(), 0.0f);
  const Eigen::Vector4f right = m * Eigen::Vector4f(1, 0, 5, 1);  // camera +x is right
  EXPECT_GT(right.x() / right.w(), 0.0f);
}

TEST(Orbit, PointSplatCoversTheGlSquareAndKeepsTheNearest) {
  OrbitCamera camera;
  camera.target_world = {0, 0, 5};
  camera.distance_m = 5;
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 6}, {0, 0, 5}, {0, 0, 7}};  // all project onto the image centre
  mesh.quality = {0.2f, 0.6f, 1.0f};                  // the middle one is nearest
  ViewStyle style;
  Image<Rgb8> out(8, 6);
  composite_orbit(mesh, camera, out, style);
  int covered = 0;
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) {
      if (out(x, y) == style.background) continue;
      ++covered;
      EXPECT_TRUE((x == 3 || x == 4) && (y == 2 || y == 3)) << x << "," << y;
      EXPECT_EQ(out(x, y), (Rgb8{153, 153, 153}));  // 0.6 grey, no normals
    }
  EXPECT_EQ(covered, 4);
  // A vertex behind the eye is clipped.
  mesh.vertices = {{0, 0, -1}};
  mesh.quality = {0.5f};
  composite_orbit(mesh, camera, out, style);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) EXPECT_EQ(out(x, y), style.background);
}

TEST(Orbit, VertexInputsAreSanitised) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 1}, {0, 0, 2}};
  EXPECT_EQ(vertex_ao(mesh, 0), 1.0f);  // no quality
  EXPECT_TRUE(vertex_normal(mesh, 0).isZero());
  mesh.quality = {kNaN, 3.0f};
  mesh.normals = {{kNaN, 0, 0}, {0, 1, 0}};
  EXPECT_EQ(vertex_ao(mesh, 0), 1.0f);
  EXPECT_EQ(vertex_ao(mesh, 1), 1.0f);
  EXPECT_TRUE(vertex_normal(mesh, 0).isZero());
  EXPECT_EQ(vertex_normal(mesh, 1), Eigen::Vector3f(0, 1, 0));
}

TEST(Composite, ASteppedViewIsTheFullViewsPixelsAtTheStep) {
  // An 8x6 frame with a half-resolution model (4x3) whose every pixel differs, and full-resolution
  // raw depth.
  ViewFrame f;
  f.intrinsics.width = 8;
  f.intrinsics.height = 6;
  f.depth_m.resize(4, 3, 0.0f);
  f.normals.resize(4, 3, Eigen::Vector3f(0, 0, -1));
  f.ssao.resize(4, 3, 0.0f);
  f.mvao.resize(4, 3, 0.0f);
  f.colour.resize(4, 3, Rgb8{0, 0, 0});
  f.raw_depth_m.resize(8, 6, 0.0f);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) {
      const int i = y * 4 + x;
      f.depth_m(x, y) = 0.5f + 0.1f * static_cast<float>(i);
      f.normals(x, y) = Eigen::Vector3f(0.05f * static_cast<float>(x), 0.1f * static_cast<float>(y), -1.0f).normalized();
      f.ssao(x, y) = static_cast<float>(i) / 12.0f;
      f.mvao(x, y) = 1.0f - static_cast<float>(i) / 12.0f;
      f.colour(x, y) = Rgb8{static_cast<std::uint8_t>(20 * i), 100, static_cast<std::uint8_t>(200 - 10 * i)};
    }
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 8; ++x) f.raw_depth_m(x, y) = 0.5f + 0.07f * static_cast<float>(y * 8 + x);
  EXPECT_EQ(model_scale(f), 2);
  for (int v = 0; v < kViewCount; ++v) {
    const View view = static_cast<View>(v);
    if (orbit_camera_view(view)) continue;
    Image<Rgb8> full;
    Image<Rgb8> half;
    composite_view(f, view, full);
    composite_view(f, view, half, {}, 2);
    ASSERT_EQ(full.width(), 8);
    ASSERT_EQ(half.width(), 4);
    ASSERT_EQ(half.height(), 3);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 4; ++x) EXPECT_EQ(half(x, y), full(2 * x, 2 * y)) << view_name(view);
  }
  ViewFrame no_model;
  EXPECT_EQ(model_scale(no_model), 1);
}

TEST(Composite, OrbitViewsOfAFrameUseItsSurface) {
  for (const View view : {View::kOrbit, View::kSplats}) {
    ViewFrame f = testing::sphere_wall_frame(64, 48);
    Image<Rgb8> out;
    composite_view(f, view, out);
    int covered = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) covered += out(x, y) != ViewStyle{}.background;
    EXPECT_EQ(covered, 0) << view_name(view);  // no surface yet
    f.surface = testing::sphere_points({0, 0, 2}, 0.5f, 40);
    composite_view(f, view, out);
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) covered += out(x, y) != ViewStyle{}.background;
    EXPECT_GT(covered, 300) << view_name(view);
    EXPECT_NE(out(32, 24), ViewStyle{}.background) << view_name(view);  // the sphere's middle
    // The same image as the view drawn directly from the fitted camera.
    Image<Rgb8> direct(64, 48);
    if (view == View::kOrbit)
      composite_orbit(*f.surface, fit_orbit(*f.surface), direct);
    else
      composite_splats(*f.surface, fit_orbit(*f.surface), direct);
    EXPECT_TRUE(std::equal(out.data(), out.data() + out.size(), direct.data()));
  }
}

/// The splats tests' camera: the eye at the origin looking along +z (world y down), a 65 x 49
/// image whose centre (32.5, 24.5) is the centre of pixel (32, 24).
OrbitCamera eye_at_origin() {
  OrbitCamera camera;
  camera.target_world = {0, 0, 5};
  camera.distance_m = 5;
  return camera;
}
constexpr int kSplatW = 65;
constexpr int kSplatH = 49;

/// A style whose splats have world radius `radius_m` on a face-less surface, lit head-on.
ViewStyle splat_style(float radius_m) {
  ViewStyle style = head_on_light();
  style.splat_spacing_m = radius_m;
  style.splat_radius_per_spacing = 1.0f;
  return style;
}

/// The world radius of a splat `r_px` pixels across at eye depth `z_m` for the splats camera.
float radius_for_pixels(float r_px, float z_m) {
  Eigen::Matrix4f projection;
  orbit_clip_from_world(eye_at_origin(), static_cast<float>(kSplatW) / kSplatH, nullptr,
                        &projection);
  return r_px * z_m / (projection(1, 1) * 0.5f * static_cast<float>(kSplatH));
}

TEST(Splats, OneSplatCoversItsDiskWithItsShade) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 5}};  // onto the centre of pixel (32, 24)
  mesh.quality = {0.6f};
  const ViewStyle style = splat_style(radius_for_pixels(3.5f, 5.0f));
  Image<Rgb8> out(kSplatW, kSplatH);
  composite_splats(mesh, eye_at_origin(), out, style);
  // The pixels whose centres lie within 3.5 pixels: dx^2 + dy^2 <= 12 (the next are 10 and 13).
  int covered = 0;
  for (int y = 0; y < kSplatH; ++y)
    for (int x = 0; x < kSplatW; ++x) {
      const int dx = x - 32;
      const int dy = y - 24;
      const bool inside = dx * dx + dy * dy <= 12;
      covered += inside;
      // One splat: sum(w x shade) / sum(w) is its shade, 0.6 x 255 (no normal: no diffuse term).
      EXPECT_EQ(out(x, y), inside ? (Rgb8{153, 153, 153}) : style.background) << x << "," << y;
    }
  EXPECT_EQ(covered, 37);
  // Twice as far, half the radius (1.75 pixels: dx^2 + dy^2 <= 2, 9 pixels).
  mesh.vertices = {{0, 0, 10}};
  composite_splats(mesh, eye_at_origin(), out, style);
  covered = 0;
  for (int y = 0; y < kSplatH; ++y)
    for (int x = 0; x < kSplatW; ++x) covered += out(x, y) != style.background;
  EXPECT_EQ(covered, 9);
  EXPECT_EQ(out(33, 25), (Rgb8{153, 153, 153}));
  EXPECT_EQ(out(34, 24), style.background);
}

TEST(Splats, RadiusIsClampedToWhatTheScreenCanShow) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 5}};
  // A splat far below a pixel still covers the pixel under its centre (kSplatMinRadiusPx).
  Image<Rgb8> out(kSplatW, kSplatH);
  const ViewStyle tiny = splat_style(radius_for_pixels(0.01f, 5.0f));
  composite_splats(mesh, eye_at_origin(), out, tiny);
  int covered = 0;
  for (int y = 0; y < kSplatH; ++y)
    for (int x = 0; x < kSplatW; ++x) covered += out(x, y) != tiny.background;
  EXPECT_EQ(covered, 1);
  EXPECT_EQ(out(32, 24), (Rgb8{255, 255, 255}));  // no quality: AO 1
  // A huge one stops at kSplatMaxRadiusPx (64): the whole 65 x 49 image, corners included
  // (32.5^2 + 24.5^2 < 64^2).
  const ViewStyle huge = splat_style(radius_for_pixels(500.0f, 5.0f));
  composite_splats(mesh, eye_at_origin(), out, huge);
  for (int y = 0; y < kSplatH; ++y)
    for (int x = 0; x < kSplatW; ++x) EXPECT_EQ(out(x, y), (Rgb8{255, 255, 255}));
  // With the largest radius, a splat 64 pixels right of the centre (x = 96.5) is clipped by its
  // centre, as GL clips a point: nothing drawn.
  Eigen::Matrix4f projection;
  orbit_clip_from_world(eye_at_origin(), static_cast<float>(kSplatW) / kSplatH, nullptr,
                        &projection);
  mesh.vertices = {{64.0f * 5.0f / (projection(0, 0) * 0.5f * kSplatW), 0, 5}};
  composite_splats(mesh, eye_at_origin(), out, huge);
  for (int y = 0; y < kSplatH; ++y)
    for (int x = 0; x < kSplatW; ++x) EXPECT_EQ(out(x, y), huge.background);
}

TEST(Splats, OverlappingSplatsAtOneDepthBlendToTheWeightedMean) {
  // Two splats of radius 6 pixels 4 pixels left and right of the image centre (32.5, 24.5), AO
  // 0.2 and 1.0.
  const float r_px = 6.0f;
  Eigen::Matrix4f projection;
  orbit_clip_from_world(eye_at_origin(), static_cast<float>(kSplatW) / kSplatH, nullptr,
                        &projection);
  const float x_m = 4.0f * 5.0f / (projection(0, 0) * 0.5f * kSplatW);
  TriangleMesh mesh;
  mesh.vertices = {{-x_m, 0, 5}, {x_m, 0, 5}};
  mesh.quality = {0.2f, 1.0f};
  const ViewStyle style = splat_style(radius_for_pixels(r_px, 5.0f));
  Image<Rgb8> out(kSplatW, kSplatH);
  composite_splats(mesh, eye_at_origin(), out, style);
  // Midway (pixel 32) the weights are equal: (0.2 + 1.0) / 2 = 0.6.
  EXPECT_EQ(out(32, 24), (Rgb8{153, 153, 153}));
  EXPECT_EQ(out(32, 20), (Rgb8{153, 153, 153}));
  // Elsewhere the Gaussian-weighted mean, w = exp(-2 d^2 / r^2); alone, each its own shade.
  for (const int x : {27, 29, 30, 31, 33, 34, 35, 37})
    for (const int y : {24, 22}) {
      const double dy = y - 24;
      const double wa = std::exp(-2.0 * ((x + 4 - 32) * (x + 4 - 32) + dy * dy) / (r_px * r_px));
      const double wb = std::exp(-2.0 * ((x - 4 - 32) * (x - 4 - 32) + dy * dy) / (r_px * r_px));
      const double inside_a = (x + 4 - 32) * (x + 4 - 32) + dy * dy < r_px * r_px;
      const double inside_b = (x - 4 - 32) * (x - 4 - 32) + dy * dy < r_px * r_px;
      const double grey =
          255.0 * (inside_a * wa * 0.2 + inside_b * wb * 1.0) / (inside_a * wa + inside_b * wb);
      // Away from a rounding boundary: the float composite lands on the same level.
      ASSERT_GT(std::abs(grey - std::floor(grey) - 0.5), 0.01) << x << "," << y;
      const auto level = static_cast<std::uint8_t>(std::floor(grey + 0.5));
      EXPECT_EQ(out(x, y), (Rgb8{level, level, level})) << x << "," << y;
    }
  EXPECT_EQ(out(27, 24), (Rgb8{51, 51, 51}));  // only the left splat: 0.2
  EXPECT_EQ(out(37, 24), (Rgb8{255, 255, 255}));
}

TEST(Splats, OnlySplatsWithinEpsilonOfTheFrontSurfaceBlend) {
  // Two splats on the axis, AO 0.2 in front and 1.0 behind; epsilon = the world radius R.
  const float radius_m = radius_for_pixels(4.0f, 5.0f);
  const ViewStyle style = splat_style(radius_m);
  Image<Rgb8> out(kSplatW, kSplatH);
  for (const bool front_first : {true, false}) {
    for (const float behind_m : {0.5f * radius_m, 2.0f * radius_m}) {
      TriangleMesh mesh;
      mesh.vertices = {{0, 0, 5}, {0, 0, 5 + behind_m}};
      mesh.quality = {0.2f, 1.0f};
      if (!front_first) {
        std::swap(mesh.vertices[0], mesh.vertices[1]);
        std::swap(mesh.quality[0], mesh.quality[1]);
      }
      composite_splats(mesh, eye_at_origin(), out, style);
      // Both centres on pixel (32, 24)'s centre: weight 1 each. Within epsilon they blend to
      // (0.2 + 1.0) / 2; beyond it the one behind is hidden wherever the front one covers.
      const bool blended = behind_m < radius_m;
      EXPECT_EQ(out(32, 24), blended ? (Rgb8{153, 153, 153}) : (Rgb8{51, 51, 51}))
          << front_first << " " << behind_m;
      if (!blended) {
        for (int y = 0; y < kSplatH; ++y)
          for (int x = 0; x < kSplatW; ++x)
            if (out(x, y) != style.background) {
              EXPECT_EQ(out(x, y), (Rgb8{51, 51, 51}));
            }
      }
    }
  }
}

TEST(Splats, ShadeIsTheOrbitViewsAndClippingAsGlPoints) {
  // A normal facing the head-on light: AO x 1; turned away to cos = 0.8: AO x (a + (1 - a) 0.8).
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 5}};
  mesh.quality = {0.8f};
  mesh.normals = {{0, 0, -1}};
  const ViewStyle style = splat_style(radius_for_pixels(2.0f, 5.0f));
  Image<Rgb8> splats(kSplatW, kSplatH);
  Image<Rgb8> points(kSplatW, kSplatH);
  for (const Eigen::Vector3f& n : {Eigen::Vector3f(0, 0, -1), Eigen::Vector3f(0.6f, 0, -0.8f)}) {
    mesh.normals = {n};
    composite_splats(mesh, eye_at_origin(), splats, style);
    composite_orbit(mesh, eye_at_origin(), points, style);
    EXPECT_EQ(splats(32, 24), points(32, 24));
  }
  EXPECT_EQ(splats(32, 24), (Rgb8{173, 173, 173}));  // 0.8 x (0.25 + 0.75 x 0.8) x 255 = 173.4
  // Behind the eye: clipped, the background everywhere.
  mesh.vertices = {{0, 0, -1}};
  composite_splats(mesh, eye_at_origin(), splats, style);
  for (int y = 0; y < kSplatH; ++y)
    for (int x = 0; x < kSplatW; ++x) EXPECT_EQ(splats(x, y), style.background);
}

TEST(Splats, SpacingIsTheMeanEdgeLengthOrTheStylesWithoutFaces) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {3, 0, 0}, {3, 4, 0}, {0, 0, 1}};
  ViewStyle style;
  EXPECT_EQ(mean_edge_length_m(mesh), 0.0f);
  EXPECT_EQ(surface_spacing_m(mesh, style), style.splat_spacing_m);  // the orbit cloud
  // One face, edges 3, 4, 5.
  mesh.faces = {{0, 1, 2}};
  EXPECT_FLOAT_EQ(mean_edge_length_m(mesh), 4.0f);
  mesh.faces.push_back({0, 1, 3});  // edges 3, sqrt(10), 1
  EXPECT_FLOAT_EQ(surface_spacing_m(mesh, style), (12.0f + 4.0f + std::sqrt(10.0f)) / 6.0f);
  mesh.faces.push_back({0, 1, 7});  // out of range: skipped
  mesh.faces.push_back({-1, 1, 2});
  EXPECT_FLOAT_EQ(mean_edge_length_m(mesh), (12.0f + 4.0f + std::sqrt(10.0f)) / 6.0f);
  mesh.vertices[3] = {kNaN, 0, 0};  // the second face is skipped too
  EXPECT_FLOAT_EQ(mean_edge_length_m(mesh), 4.0f);
}

/// Reads an 8-bit RGB PNG with libpng (test-side decoder).
bool read_rgb_png(const std::string& path, Image<Rgb8>& out) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return false;
  image.format = PNG_FORMAT_RGB;
  out.resize(static_cast<int>(image.width), static_cast<int>(image.height));
  const bool ok = png_image_finish_read(&image, nullptr, out.data(), 0, nullptr) != 0;
  png_image_free(&image);
  return ok;
}

TEST(RgbPng, RoundTrip) {
  testing::ScratchDir dir;
  Image<Rgb8> image(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      image(x, y) = {static_cast<std::uint8_t>(50 * x), static_cast<std::uint8_t>(100 * y),
                     static_cast<std::uint8_t>(x + y)};
  write_colour_png(dir.file("a.png"), image);
  Image<Rgb8> back;
  ASSERT_TRUE(read_rgb_png(dir.file("a.png"), back));
  EXPECT_EQ(back, image);
}

TEST(RgbPng, ErrorsNameTheFile) {
  testing::ScratchDir dir;
  const std::string bad = dir.file("missing-folder/a.png");
  try {
    write_colour_png(bad, Image<Rgb8>(2, 2));
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ExitCode::kFailure);
    EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  EXPECT_THROW(write_colour_png(dir.file("b.png"), Image<Rgb8>()), Error);
}

}  // namespace
}  // namespace aoscan
