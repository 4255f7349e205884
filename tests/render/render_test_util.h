/// @file render_test_util.h
/// @brief Analytic scenes for the render tests: a sphere in front of a wall seen by a pinhole
/// camera, with exact depth and normals and made-up SSAO / MVAO / raw-depth patterns.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

#include <Eigen/Core>

#include "core/mesh.h"
#include "render/view_frame.h"

namespace aoscan::testing {

/// A `width` x `height` frame: a sphere (centre (0.1, -0.05, 1.5) m, radius 0.5 m) in front of a
/// wall at z = 2.5 m that covers the image except a 10 px band on the right (no surface there).
/// SSAO and MVAO vary smoothly in [0, 1] with a NaN patch each; the fused colour is a pattern of
/// x and y; the raw depth is the depth with a 5 px invalid border.
inline ViewFrame sphere_wall_frame(int width = 160, int height = 120) {
  ViewFrame f;
  f.sequence = 7;
  f.intrinsics.width = width;
  f.intrinsics.height = height;
  f.intrinsics.fx = f.intrinsics.fy = 0.9 * width;
  f.intrinsics.cx = 0.5 * width - 0.5;
  f.intrinsics.cy = 0.5 * height - 0.5;
  f.depth_m.resize(width, height);
  f.normals.resize(width, height, Eigen::Vector3f::Zero());
  f.ssao.resize(width, height);
  f.mvao.resize(width, height);
  f.colour.resize(width, height);
  f.raw_depth_m.resize(width, height);
  const Eigen::Vector3f centre(0.1f, -0.05f, 1.5f);
  const float radius = 0.5f;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3f ray =
          f.intrinsics.unproject(static_cast<float>(x), static_cast<float>(y), 1.0f);
      // |t ray - c|^2 = r^2 → t^2 |ray|^2 - 2 t ray.c + |c|^2 - r^2 = 0, nearest root.
      const float a = ray.squaredNorm();
      const float b = ray.dot(centre);
      const float disc = b * b - a * (centre.squaredNorm() - radius * radius);
      float depth = 0.0f;
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      if (disc >= 0.0f) {
        const float t = (b - std::sqrt(disc)) / a;
        depth = t;  // ray.z = 1, so t is the depth
        normal = (t * ray - centre).normalized();
      } else if (x < width - 10) {
        depth = 2.5f;
        normal = Eigen::Vector3f(0.0f, 0.0f, -1.0f);
      }
      f.depth_m(x, y) = depth;
      f.normals(x, y) = normal;
      f.ssao(x, y) = 0.5f + 0.5f * std::sin(0.11f * x) * std::cos(0.07f * y);
      f.mvao(x, y) = 0.6f + 0.4f * std::cos(0.05f * x + 0.09f * y);
      f.colour(x, y) = {static_cast<std::uint8_t>(40 + (7 * x) % 200),
                        static_cast<std::uint8_t>(30 + (5 * y) % 220),
                        static_cast<std::uint8_t>((3 * x + 11 * y) % 256)};
      const bool border = x < 5 || y < 5 || x >= width - 5 || y >= height - 5;
      f.raw_depth_m(x, y) = border ? 0.0f : (depth > 0.0f ? depth + 0.001f * (x % 3) : 0.0f);
    }
  }
  for (int y = 10; y < std::min(20, height); ++y)
    for (int x = 10; x < std::min(20, width); ++x) f.ssao(x, y) = nan;
  for (int y = 10; y < std::min(20, height); ++y)
    for (int x = 30; x < std::min(40, width); ++x) f.mvao(x, y) = nan;
  f.tracking_state = "ok";
  f.hud.fps = 29.5;
  f.hud.stage_ms = {{"preprocess", 12.25}, {"track", 8.5}};
  f.hud.frames_processed = 7;
  f.hud.frames_dropped = 1;
  return f;
}

/// `f` with its model images (depth, normals, SSAO, MVAO, colour) at 1/`scale` of the frame's
/// resolution,
/// as the pipeline publishes a pyramid-level raycast: every `scale`-th pixel of each row and
/// column. The raw depth stays at full resolution.
inline ViewFrame model_at_fraction(const ViewFrame& f, int scale) {
  ViewFrame out = f;
  const auto shrink = [scale](const auto& full, auto& small) {
    small.resize(full.width() / scale, full.height() / scale, full(0, 0));  // all overwritten
    for (int y = 0; y < small.height(); ++y)
      for (int x = 0; x < small.width(); ++x) small(x, y) = full(x * scale, y * scale);
  };
  shrink(f.depth_m, out.depth_m);
  shrink(f.normals, out.normals);
  shrink(f.ssao, out.ssao);
  shrink(f.mvao, out.mvao);
  if (!f.colour.empty()) shrink(f.colour, out.colour);
  return out;
}

/// `small` (from model_at_fraction) with its model images enlarged back to the frame's size by
/// pixel replication: what every view must show for it.
inline ViewFrame model_replicated(const ViewFrame& small) {
  ViewFrame out = small;
  const int scale = small.intrinsics.width / small.depth_m.width();
  const auto grow = [scale](const auto& part, auto& full) {
    full.resize(part.width() * scale, part.height() * scale, part(0, 0));  // all overwritten
    for (int y = 0; y < full.height(); ++y)
      for (int x = 0; x < full.width(); ++x) full(x, y) = part(x / scale, y / scale);
  };
  grow(small.depth_m, out.depth_m);
  grow(small.normals, out.normals);
  grow(small.ssao, out.ssao);
  grow(small.mvao, out.mvao);
  if (!small.colour.empty()) grow(small.colour, out.colour);
  return out;
}

/// Points on a sphere (centre `c`, radius `r`) with outward normals and AO = 0.3 + 0.7 (up to
/// 1) depending on height, `n` x `n` latitude-longitude samples.
inline std::shared_ptr<TriangleMesh> sphere_points(const Eigen::Vector3f& c, float r, int n) {
  auto mesh = std::make_shared<TriangleMesh>();
  for (int i = 0; i < n; ++i) {
    const float theta = 3.14159265f * (static_cast<float>(i) + 0.5f) / static_cast<float>(n);
    for (int j = 0; j < n; ++j) {
      const float phi = 6.2831853f * static_cast<float>(j) / static_cast<float>(n);
      const Eigen::Vector3f dir(std::sin(theta) * std::cos(phi), std::cos(theta),
                                std::sin(theta) * std::sin(phi));
      mesh->vertices.push_back(c + r * dir);
      mesh->normals.push_back(dir);
      mesh->quality.push_back(0.3f + 0.35f * (1.0f + dir.y()));
    }
  }
  return mesh;
}

/// sphere_points() with faces: each latitude band's quads as two triangles (open at the poles).
inline std::shared_ptr<TriangleMesh> sphere_mesh(const Eigen::Vector3f& c, float r, int n) {
  std::shared_ptr<TriangleMesh> mesh = sphere_points(c, r, n);
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j < n; ++j) {
      const int a = i * n + j;
      const int b = i * n + (j + 1) % n;
      mesh->faces.push_back({a, a + n, b});
      mesh->faces.push_back({b, a + n, b + n});
    }
  return mesh;
}

}  // namespace aoscan::testing
