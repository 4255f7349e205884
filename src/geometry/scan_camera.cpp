/// @file scan_camera.cpp
/// @brief Pinhole and equirectangular scan cameras: projection and pixel footprint.
#include "geometry/scan_camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace aoscan {
namespace {

constexpr double kPi = M_PI;  // as pixels_per_metre_at_1m() in the header

/// atan2(y, x) in float without branches (the compiler turns the selects into blends): the
/// octant's angle by the arctangent polynomial of Cephes' atanf on [-tan(pi/8), tan(pi/8)]
/// (a few float ulp), then the octant's offset. (0, 0) gives 0; the sign follows y's, -0 included.
inline float atan2_poly(float y, float x) {
  constexpr float kPiF = static_cast<float>(kPi);
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float hi = std::max(ax, ay), lo = std::min(ax, ay);
  const float a = lo / std::max(hi, std::numeric_limits<float>::min());  // [0, 1]
  // Above tan(pi/8), atan(a) = pi/4 + atan((a - 1) / (a + 1)).
  const bool upper = a > 0.41421356f;
  const float reduced = (a - 1.0f) / (a + 1.0f);
  const float r = upper ? reduced : a;
  const float z = r * r;
  const float poly =
      ((8.05374449538e-2f * z - 1.38776856032e-1f) * z + 1.99777106478e-1f) * z - 3.33329491539e-1f;
  const float octant = poly * z * r + r + (upper ? 0.25f * kPiF : 0.0f);
  const float first = ay > ax ? 0.5f * kPiF - octant : octant;  // [0, pi/2]
  const float half = x < 0.0f ? kPiF - first : first;           // [0, pi]
  return std::copysign(half, y);
}

}  // namespace

ScanCamera ScanCamera::make_pinhole(const Intrinsics& intrinsics) {
  ScanCamera camera;
  camera.projection = ScanProjection::kPinhole;
  camera.width = intrinsics.width;
  camera.height = intrinsics.height;
  camera.pinhole = intrinsics;
  return camera;
}

ScanCamera ScanCamera::make_equirectangular(int h) {
  ScanCamera camera;
  camera.projection = ScanProjection::kEquirectangular;
  camera.width = 2 * h;
  camera.height = h;
  return camera;
}

ScanCamera ScanCamera::equirectangular_for_points(long long points) {
  const double h = std::sqrt(kPi * static_cast<double>(std::max(points, 0LL)) / 3.0);
  return make_equirectangular(std::max(1, static_cast<int>(std::lround(h))));
}

bool ScanCamera::project(const Eigen::Vector3f& p, float& u, float& v) const {
  if (!p.allFinite()) return false;
  if (projection == ScanProjection::kPinhole) {
    if (!(p.z() > 0.0f)) return false;
    u = static_cast<float>(pinhole.fx * p.x() / p.z() + pinhole.cx);
    v = static_cast<float>(pinhole.fy * p.y() / p.z() + pinhole.cy);
    return true;
  }
  const double x = p.x(), y = p.y(), z = p.z();
  const double horizontal = std::sqrt(x * x + y * y);
  if (horizontal == 0.0 && z == 0.0) return false;
  const double phi = std::atan2(y, x);             // [-pi, pi]
  const double theta = std::atan2(horizontal, z);  // [0, pi]
  u = static_cast<float>((phi + kPi) / (2.0 * kPi) * width);
  v = static_cast<float>(theta / kPi * height);
  return true;
}

Eigen::Vector3d ScanCamera::ray(double u, double v) const {
  if (projection == ScanProjection::kPinhole) return pinhole.unproject(u, v, 1.0).normalized();
  const double phi = u / width * 2.0 * kPi - kPi;
  const double theta = v / height * kPi;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

bool ScanCamera::pixel_of(const Eigen::Vector3f& p, int& x, int& y) const {
  float u = 0.0f, v = 0.0f;
  if (!project(p, u, v)) return false;
  if (projection == ScanProjection::kPinhole) {
    u += 0.5f;  // pixel centres at integers: pixel x covers [x - 0.5, x + 0.5)
    v += 0.5f;
  }
  // Compare as floats before converting: a point far off a pinhole camera's axis projects beyond
  // any int.
  if (!(u >= 0.0f && v >= 0.0f && u <= static_cast<float>(width) &&
        v <= static_cast<float>(height)))
    return false;
  x = static_cast<int>(u);
  y = static_cast<int>(v);
  if (projection == ScanProjection::kEquirectangular) {
    x = std::min(x, width - 1);  // phi = pi and theta = pi land on the last column / row
    y = std::min(y, height - 1);
  }
  return x < width && y < height;
}

void ScanCamera::pixels_of(const float* xs, const float* ys, const float* zs, int n, int* px,
                           int* py) const {
  // Bitwise & between the tests, so that the loop has no branch: a point that fails a test
  // computes garbage that the selects drop (src/CMakeLists.txt lets the compiler do so).
  const float w = static_cast<float>(width), h = static_cast<float>(height);
  if (projection == ScanProjection::kPinhole) {
    const float fx = static_cast<float>(pinhole.fx), fy = static_cast<float>(pinhole.fy);
    const float cx = static_cast<float>(pinhole.cx) + 0.5f,
                cy = static_cast<float>(pinhole.cy) + 0.5f;
    for (int k = 0; k < n; ++k) {
      const float x = xs[k], y = ys[k], z = zs[k];
      const float u = fx * x / z + cx, v = fy * y / z + cy;
      // Finite, in front and inside (NaN fails every comparison).
      const bool in = (x - x == 0.0f) & (y - y == 0.0f) & (z > 0.0f) & (u >= 0.0f) & (v >= 0.0f) &
                      (u < w) & (v < h);
      px[k] = in ? static_cast<int>(in ? u : 0.0f) : -1;
      py[k] = static_cast<int>(in ? v : 0.0f);
    }
    return;
  }
  const float u_scale = static_cast<float>(width / (2.0 * kPi));
  const float v_scale = static_cast<float>(height / kPi);
  const float pi = static_cast<float>(kPi);
  for (int k = 0; k < n; ++k) {
    const float x = xs[k], y = ys[k], z = zs[k];
    // The polar angle is that of the point scaled to at most 1, whose squares neither overflow
    // nor underflow.
    const float scale = 1.0f / std::max(std::max(std::fabs(x), std::fabs(y)),
                                        std::max(std::fabs(z), std::numeric_limits<float>::min()));
    const float sx = x * scale, sy = y * scale;
    const float horizontal = std::sqrt(sx * sx + sy * sy);
    const float u = (atan2_poly(y, x) + pi) * u_scale;
    const float v = atan2_poly(horizontal, z * scale) * v_scale;
    const bool in = (x - x == 0.0f) & (y - y == 0.0f) & (z - z == 0.0f) &
                    ((horizontal != 0.0f) | (z != 0.0f)) & (u >= 0.0f) & (v >= 0.0f) & (u <= w) &
                    (v <= h);
    // u = width (phi = pi) and v = height (theta = pi) land on the last column and row.
    px[k] = in ? static_cast<int>(std::min(in ? u : 0.0f, w - 1.0f)) : -1;
    py[k] = static_cast<int>(std::min(in ? v : 0.0f, h - 1.0f));
  }
}

ScanCamera::SphereRow ScanCamera::sphere_row(int y) const {
  SphereRow row;
  const double theta = (y + 0.5) * kPi / height;
  row.sin_theta = static_cast<float>(std::sin(theta));
  row.cos_theta = static_cast<float>(std::cos(theta));
  row.v_centre = static_cast<float>(y + 0.5);
  row.u_scale = static_cast<float>(width / (2.0 * kPi));
  row.v_scale = static_cast<float>(height / kPi);
  return row;
}

void ScanCamera::SphereRow::offsets(float tangent, const Eigen::Vector2f* o, int n, float* du,
                                    float* dv) const {
  for (int k = 0; k < n; ++k) {
    // The direction in the frame of the row's azimuth 0: the centre's (sin_theta, 0, cos_theta)
    // plus the offset along the unit vectors of azimuth (0, 1, 0) and polar angle
    // (cos_theta, 0, -sin_theta).
    const float ox = o[k].x(), oy = o[k].y();
    const float x = sin_theta + tangent * oy * cos_theta;
    const float y = tangent * ox;
    const float z = cos_theta - tangent * oy * sin_theta;
    du[k] = atan2_poly(y, x) * u_scale;
    dv[k] = atan2_poly(std::sqrt(x * x + y * y), z) * v_scale - v_centre;
  }
}

bool ScanCamera::valid() const {
  if (width <= 0 || height <= 0) return false;
  if (projection == ScanProjection::kEquirectangular) return width == 2 * height;
  return pinhole.valid() && pinhole.width == width && pinhole.height == height;
}

}  // namespace aoscan
