/// @file composite.cpp
/// @brief CPU shading of the views (the shaders' reference) and the orbit point splatter.
#include "render/composite.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "core/status.h"

namespace aoscan {
namespace {

/// The depth colour map's stops (8-bit values, evenly spaced from near = blue to far = red);
/// shaders/depth.frag holds the same table.
constexpr float kDepthStops[5][3] = {
    {26, 26, 153}, {0, 179, 230}, {51, 204, 51}, {242, 217, 26}, {204, 26, 26}};

Rgb8 grey(float c) {
  const std::uint8_t v = to_u8(c);
  return {v, v, v};
}

bool has_surface(float depth_m, const Eigen::Vector3f& n) {
  return depth_m > 0.0f && (n.x() != 0.0f || n.y() != 0.0f || n.z() != 0.0f);
}

/// The AO of the model views: clamped to [0, 1]; unobserved (NaN or negative) counts as open.
float open_if_unobserved(float mvao) {
  return mvao >= 0.0f ? std::min(mvao, 1.0f) : 1.0f;
}

float diffuse(const Eigen::Vector3f& n, const Eigen::Vector3f& to_light, float ambient) {
  const float lambert =
      std::max(0.0f, n.x() * to_light.x() + n.y() * to_light.y() + n.z() * to_light.z());
  return ambient + (1.0f - ambient) * lambert;
}

/// The orbit views' grey of mesh vertex `i`: its AO x the diffuse term of its normal seen from
/// the eye (no diffuse term without a normal).
float orbit_shade(const TriangleMesh& mesh, std::size_t i, const Eigen::Matrix3f& eye_R_world,
                  const Eigen::Vector3f& to_light_eye, float ambient) {
  float shade = vertex_ao(mesh, i);
  const Eigen::Vector3f n_world = vertex_normal(mesh, i);
  if (!n_world.isZero(0.0f))
    shade *= diffuse((eye_R_world * n_world).normalized(), to_light_eye, ambient);
  return shade;
}

/// The orbit views' camera for an image of `out`'s size.
struct OrbitSetup {
  Eigen::Matrix4f clip_from_world;
  Eigen::Matrix4f eye_from_world;
  Eigen::Matrix4f clip_from_eye;
  Eigen::Matrix3f eye_R_world;
  Eigen::Vector3f to_light_eye;  ///< GL eye coordinates (y up, z backwards)
};

/// What both orbit views start with: `out` filled with the background and `setup` for its size;
/// false when `out` is empty.
bool start_orbit_view(const OrbitCamera& camera, const ViewStyle& style, Image<Rgb8>& out,
                      OrbitSetup& setup) {
  out.fill(style.background);
  if (out.width() == 0 || out.height() == 0) return false;
  setup.clip_from_world = orbit_clip_from_world(
      camera, static_cast<float>(out.width()) / static_cast<float>(out.height()),
      &setup.eye_from_world, &setup.clip_from_eye);
  setup.eye_R_world = setup.eye_from_world.topLeftCorner<3, 3>();
  // The camera-frame light flipped.
  setup.to_light_eye = {style.to_light_camera.x(), -style.to_light_camera.y(),
                        -style.to_light_camera.z()};
  return true;
}

}  // namespace

Eigen::Vector3f vertex_normal(const TriangleMesh& mesh, std::size_t i) {
  if (mesh.normals.size() != mesh.vertices.size()) return Eigen::Vector3f::Zero();
  const Eigen::Vector3f& n = mesh.normals[i];
  return n.allFinite() ? n : Eigen::Vector3f::Zero();
}

float vertex_ao(const TriangleMesh& mesh, std::size_t i) {
  if (mesh.quality.size() != mesh.vertices.size()) return 1.0f;
  const float q = mesh.quality[i];
  return q >= 0.0f ? std::min(q, 1.0f) : 1.0f;
}

const char* view_name(View view) {
  switch (view) {
    case View::kShaded:
      return "shaded";
    case View::kSsao:
      return "ssao";
    case View::kMvao:
      return "mvao";
    case View::kColour:
      return "colour";
    case View::kColourMvao:
      return "colour_mvao";
    case View::kNormals:
      return "normals";
    case View::kDepth:
      return "depth";
    case View::kOrbit:
      return "orbit";
    case View::kSplats:
      return "splats";
  }
  return "unknown";
}

View next_view(View view) {
  return static_cast<View>((static_cast<int>(view) + 1) % kViewCount);
}

std::uint8_t to_u8(float c) {
  if (!(c > 0.0f)) return 0;  // also NaN
  if (c >= 1.0f) return 255;
  return static_cast<std::uint8_t>(std::floor(c * 255.0f + 0.5f));
}

Rgb8 shade_mvao(float depth_m, const Eigen::Vector3f& n, float mvao, const ViewStyle& style) {
  if (!has_surface(depth_m, n)) return style.background;
  return grey(open_if_unobserved(mvao) * diffuse(n, style.to_light_camera, style.ambient));
}

Rgb8 shade_ssao(float ssao, const ViewStyle& style) {
  if (!(ssao >= 0.0f)) return style.background;
  return grey(std::min(ssao, 1.0f));
}

Rgb8 shade_mvao_grey(float depth_m, const Eigen::Vector3f& n, float mvao, const ViewStyle& style) {
  if (!has_surface(depth_m, n)) return style.background;
  return shade_ssao(mvao, style);
}

Rgb8 shade_colour(float depth_m, const Eigen::Vector3f& n, Rgb8 colour, const ViewStyle& style) {
  return has_surface(depth_m, n) ? colour : style.background;
}

Rgb8 shade_colour_mvao(float depth_m, const Eigen::Vector3f& n, Rgb8 colour, float mvao,
                       const ViewStyle& style) {
  if (!has_surface(depth_m, n)) return style.background;
  const float ao = open_if_unobserved(mvao);
  return {to_u8(static_cast<float>(colour.r) / 255.0f * ao),
          to_u8(static_cast<float>(colour.g) / 255.0f * ao),
          to_u8(static_cast<float>(colour.b) / 255.0f * ao)};
}

Rgb8 shade_normal(float depth_m, const Eigen::Vector3f& n, const ViewStyle& style) {
  if (!has_surface(depth_m, n)) return style.background;
  return {to_u8(0.5f + 0.5f * n.x()), to_u8(0.5f - 0.5f * n.y()), to_u8(0.5f - 0.5f * n.z())};
}

Rgb8 shade_depth(float depth_m, const ViewStyle& style) {
  if (!(depth_m > 0.0f)) return style.background;
  const float range = std::max(style.depth_max_m - style.depth_min_m, 1e-6f);
  const float t = std::clamp((depth_m - style.depth_min_m) / range, 0.0f, 1.0f);
  const int i = std::min(static_cast<int>(t * 4.0f), 3);
  const float f = t * 4.0f - static_cast<float>(i);
  Rgb8 out;
  std::uint8_t* channels[3] = {&out.r, &out.g, &out.b};
  for (int c = 0; c < 3; ++c)
    *channels[c] =
        to_u8((kDepthStops[i][c] + (kDepthStops[i + 1][c] - kDepthStops[i][c]) * f) / 255.0f);
  return out;
}

OrbitCamera fit_orbit(const TriangleMesh& mesh) {
  OrbitCamera camera;
  if (mesh.empty()) return camera;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = -lo;
  for (const Eigen::Vector3f& v : mesh.vertices) {
    if (!v.allFinite()) continue;
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  if (!(lo.array() <= hi.array()).all()) return camera;
  camera.target_world = 0.5f * (lo + hi);
  const float radius = std::max(0.5f * (hi - lo).norm(), 0.05f);
  camera.distance_m = 1.1f * radius / std::sin(0.5f * camera.fov_y_rad);
  return camera;
}

Eigen::Matrix4f orbit_clip_from_world(const OrbitCamera& camera, float aspect,
                                      Eigen::Matrix4f* view, Eigen::Matrix4f* projection) {
  const float pitch = std::clamp(camera.pitch_rad, -kOrbitMaxPitchRad, kOrbitMaxPitchRad);
  const glm::vec3 forward(std::sin(camera.yaw_rad) * std::cos(pitch), std::sin(pitch),
                          std::cos(camera.yaw_rad) * std::cos(pitch));
  const glm::vec3 target(camera.target_world.x(), camera.target_world.y(), camera.target_world.z());
  const float distance = std::max(camera.distance_m, 1e-3f);
  const glm::mat4 eye_from_world =
      glm::lookAt(target - distance * forward, target, glm::vec3(0.0f, -1.0f, 0.0f));
  const glm::mat4 clip_from_eye = glm::perspective(camera.fov_y_rad, std::max(aspect, 1e-3f),
                                                   0.01f * distance, 100.0f * distance);
  const glm::mat4 clip_from_world = clip_from_eye * eye_from_world;
  if (view) *view = Eigen::Map<const Eigen::Matrix4f>(glm::value_ptr(eye_from_world));
  if (projection) *projection = Eigen::Map<const Eigen::Matrix4f>(glm::value_ptr(clip_from_eye));
  return Eigen::Map<const Eigen::Matrix4f>(glm::value_ptr(clip_from_world));
}

void composite_orbit(const TriangleMesh& mesh, const OrbitCamera& camera, Image<Rgb8>& out,
                     const ViewStyle& style) {
  OrbitSetup setup;
  if (!start_orbit_view(camera, style, out, setup)) return;
  const int width = out.width();
  const int height = out.height();
  const float half = 0.5f * style.point_size_px;
  thread_local std::vector<float> depth;
  depth.assign(static_cast<std::size_t>(width) * height, std::numeric_limits<float>::infinity());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector4f clip = setup.clip_from_world * mesh.vertices[i].homogeneous();
    const float w = clip.w();
    if (!(w > 0.0f) || std::abs(clip.x()) > w || std::abs(clip.y()) > w || std::abs(clip.z()) > w)
      continue;  // GL clips a point by its centre
    const float xw = (clip.x() / w * 0.5f + 0.5f) * static_cast<float>(width);
    const float yw = (clip.y() / w * 0.5f + 0.5f) * static_cast<float>(height);
    const float zw = clip.z() / w * 0.5f + 0.5f;
    const Rgb8 colour =
        grey(orbit_shade(mesh, i, setup.eye_R_world, setup.to_light_eye, style.ambient));
    // Pixels whose centres (x + 0.5, y + 0.5) lie in [xw - half, xw + half) (GL point rule).
    const int x0 = std::max(0, static_cast<int>(std::ceil(xw - half - 0.5f)));
    const int x1 = std::min(width - 1, static_cast<int>(std::ceil(xw + half - 0.5f)) - 1);
    const int y0 = std::max(0, static_cast<int>(std::ceil(yw - half - 0.5f)));
    const int y1 = std::min(height - 1, static_cast<int>(std::ceil(yw + half - 0.5f)) - 1);
    for (int y = y0; y <= y1; ++y) {
      const int row = height - 1 - y;  // GL rows go up, image rows go down
      for (int x = x0; x <= x1; ++x) {
        float& d = depth[static_cast<std::size_t>(row) * width + x];
        if (zw < d) {
          d = zw;
          out(x, row) = colour;
        }
      }
    }
  }
}

float mean_edge_length_m(const TriangleMesh& mesh) {
  const std::size_t n = mesh.vertices.size();
  double sum = 0.0;
  std::size_t edges = 0;
  for (const Eigen::Vector3i& f : mesh.faces) {
    if ((f.array() < 0).any() || (f.array().cast<std::size_t>() >= n).any()) continue;
    const Eigen::Vector3f& a = mesh.vertices[static_cast<std::size_t>(f[0])];
    const Eigen::Vector3f& b = mesh.vertices[static_cast<std::size_t>(f[1])];
    const Eigen::Vector3f& c = mesh.vertices[static_cast<std::size_t>(f[2])];
    if (!a.allFinite() || !b.allFinite() || !c.allFinite()) continue;
    sum += static_cast<double>((b - a).norm() + (c - b).norm() + (a - c).norm());
    edges += 3;
  }
  return edges > 0 ? static_cast<float>(sum / static_cast<double>(edges)) : 0.0f;
}

float surface_spacing_m(const TriangleMesh& mesh, const ViewStyle& style) {
  const float edge_m = mean_edge_length_m(mesh);
  return edge_m > 0.0f ? edge_m : style.splat_spacing_m;
}

void composite_splats(const TriangleMesh& mesh, const OrbitCamera& camera, Image<Rgb8>& out,
                      const ViewStyle& style) {
  OrbitSetup setup;
  if (!start_orbit_view(camera, style, out, setup)) return;
  const int width = out.width();
  const int height = out.height();
  const Eigen::Matrix4f& clip_from_eye = setup.clip_from_eye;
  const float radius_m = style.splat_radius_per_spacing * surface_spacing_m(mesh, style);
  const float epsilon_m = radius_m;  // the blending depth: one splat radius (Scanopy)
  const float radius_px_m = radius_m * clip_from_eye(1, 1) * 0.5f * static_cast<float>(height);
  // The splats on screen (window coordinates, GL rows going up), as shaders/splats.vert makes
  // them, in vertex order.
  struct Splat {
    float x, y;        // centre (pixels)
    float depth;       // window depth of the centre
    float depth_back;  // window depth of the centre pushed back by epsilon
    float radius;      // pixels
    float shade;
  };
  thread_local std::vector<Splat> splats;
  splats.clear();
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector4f eye = setup.eye_from_world * mesh.vertices[i].homogeneous();
    const Eigen::Vector4f clip = clip_from_eye * eye;
    const float w = clip.w();
    if (!(w > 0.0f) || std::abs(clip.x()) > w || std::abs(clip.y()) > w || std::abs(clip.z()) > w)
      continue;  // GL clips a point by its centre
    const Eigen::Vector4f back =
        clip_from_eye * Eigen::Vector4f(eye.x(), eye.y(), eye.z() - epsilon_m, 1.0f);
    splats.push_back({(clip.x() / w * 0.5f + 0.5f) * static_cast<float>(width),
                      (clip.y() / w * 0.5f + 0.5f) * static_cast<float>(height),
                      clip.z() / w * 0.5f + 0.5f, back.z() / back.w() * 0.5f + 0.5f,
                      std::clamp(radius_px_m / -eye.z(), kSplatMinRadiusPx, kSplatMaxRadiusPx),
                      orbit_shade(mesh, i, setup.eye_R_world, setup.to_light_eye, style.ambient)});
  }
  // Calls `visit(pixel index, squared distance)` for each pixel whose centre lies within the
  // splat's disk (strictly: the GL point of 2 r + 1 pixels holds them all).
  const auto for_each_pixel = [&](const Splat& s, const auto& visit) {
    const int x0 = std::max(0, static_cast<int>(std::floor(s.x - s.radius)));
    const int x1 = std::min(width - 1, static_cast<int>(std::floor(s.x + s.radius)));
    const int y0 = std::max(0, static_cast<int>(std::floor(s.y - s.radius)));
    const int y1 = std::min(height - 1, static_cast<int>(std::floor(s.y + s.radius)));
    const float r2 = s.radius * s.radius;
    for (int y = y0; y <= y1; ++y) {
      const float dy = static_cast<float>(y) + 0.5f - s.y;
      for (int x = x0; x <= x1; ++x) {
        const float dx = static_cast<float>(x) + 0.5f - s.x;
        const float d2 = dx * dx + dy * dy;
        if (d2 < r2) visit(static_cast<std::size_t>(y) * width + x, d2);
      }
    }
  };
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  // Pass 1: the depth of the front surface, pushed back by epsilon.
  thread_local std::vector<float> front;
  front.assign(pixels, std::numeric_limits<float>::infinity());
  for (const Splat& s : splats)
    for_each_pixel(s, [&](std::size_t p, float) { front[p] = std::min(front[p], s.depth_back); });
  // Pass 2: the Gaussian-weighted sums of the splats within epsilon of the front.
  thread_local std::vector<Eigen::Vector2f> sums;  // (sum of w x shade, sum of w)
  sums.assign(pixels, Eigen::Vector2f::Zero());
  for (const Splat& s : splats) {
    const float inv_two_sigma2 = 2.0f / (s.radius * s.radius);  // sigma = r / 2
    for_each_pixel(s, [&](std::size_t p, float d2) {
      if (!(s.depth <= front[p])) return;
      const float w = std::exp(-d2 * inv_two_sigma2);
      sums[p] += Eigen::Vector2f(w * s.shade, w);
    });
  }
  // Pass 3: normalise.
  for (int y = 0; y < height; ++y) {
    Rgb8* dst = out.row(height - 1 - y);  // GL rows go up, image rows go down
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector2f& sum = sums[static_cast<std::size_t>(y) * width + x];
      if (sum.y() > 0.0f) dst[x] = grey(sum.x() / sum.y());
    }
  }
}

int model_scale(const ViewFrame& frame) {
  const int scale = image_scale(frame.depth_m, frame.intrinsics.width, frame.intrinsics.height);
  return scale > 0 ? scale : 1;
}

void composite_view(const ViewFrame& frame, View view, Image<Rgb8>& out, const ViewStyle& style,
                    int step) {
  step = std::max(step, 1);
  const int width = frame.intrinsics.width;
  const int height = frame.intrinsics.height;
  const int out_width = width / step;
  const int out_height = height / step;
  if (out.width() != out_width || out.height() != out_height) out.resize(out_width, out_height);
  if (orbit_camera_view(view)) {
    if (frame.surface && !frame.surface->empty()) {
      const OrbitCamera camera = fit_orbit(*frame.surface);
      if (view == View::kOrbit)
        composite_orbit(*frame.surface, camera, out, style);
      else
        composite_splats(*frame.surface, camera, out, style);
    } else {
      out.fill(style.background);
    }
    return;
  }
  // Frame pixels per image pixel, 0 = no data. MVAO and normals are read at the depth's pixel.
  const int model = image_scale(frame.depth_m, width, height);
  const int normals = model > 0 && image_scale(frame.normals, width, height) == model ? model : 0;
  const int mvao = model > 0 && image_scale(frame.mvao, width, height) == model ? model : 0;
  const int colour = model > 0 && image_scale(frame.colour, width, height) == model ? model : 0;
  // Without a colour image the colour views show the shaded view.
  if ((view == View::kColour || view == View::kColourMvao) && colour == 0) view = View::kShaded;
  const int ssao = image_scale(frame.ssao, width, height);
  const int raw = image_scale(frame.raw_depth_m, width, height);
  const Image<float>& depth_source = raw > 0 ? frame.raw_depth_m : frame.depth_m;
  const int depth_source_scale = raw > 0 ? raw : model;
  const float kNoData = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Vector3f kNoNormal = Eigen::Vector3f::Zero();
  for (int oy = 0; oy < out_height; ++oy) {
    Rgb8* dst = out.row(oy);
    const int y = oy * step;
    for (int ox = 0; ox < out_width; ++ox) {
      const int x = ox * step;
      const float d = model > 0 ? frame.depth_m(x / model, y / model) : 0.0f;
      const Eigen::Vector3f& n = normals > 0 ? frame.normals(x / normals, y / normals) : kNoNormal;
      switch (view) {
        case View::kShaded:
          dst[ox] = shade_mvao(d, n, mvao > 0 ? frame.mvao(x / mvao, y / mvao) : kNoData, style);
          break;
        case View::kSsao:
          dst[ox] = shade_ssao(ssao > 0 ? frame.ssao(x / ssao, y / ssao) : kNoData, style);
          break;
        case View::kMvao:
          dst[ox] =
              shade_mvao_grey(d, n, mvao > 0 ? frame.mvao(x / mvao, y / mvao) : kNoData, style);
          break;
        case View::kColour:
          dst[ox] = shade_colour(d, n, frame.colour(x / colour, y / colour), style);
          break;
        case View::kColourMvao:
          dst[ox] = shade_colour_mvao(d, n, frame.colour(x / colour, y / colour),
                                     mvao > 0 ? frame.mvao(x / mvao, y / mvao) : kNoData, style);
          break;
        case View::kNormals:
          dst[ox] = shade_normal(d, n, style);
          break;
        case View::kDepth:
          dst[ox] = shade_depth(depth_source_scale > 0
                                   ? depth_source(x / depth_source_scale, y / depth_source_scale)
                                   : 0.0f,
                               style);
          break;
        case View::kOrbit:
        case View::kSplats:
          break;
      }
    }
  }
}

}  // namespace aoscan
