/// @file registration.cpp
/// @brief Depth-edge to colour-edge registration (see registration.h).
#include "registration.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/status.h"
#include "io/camera_json.h"
#include "io/png_read.h"
#include "io/tum.h"

namespace aoscan::colour_registration {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kParams = 9;  // rx ry rz tx ty tz f cx cy

/// Bilinear sample of `img` at (u, v); the caller keeps (u, v) inside [0, w-1] x [0, h-1].
float bilinear(const Image<float>& img, double u, double v) {
  const int x0 = std::min(static_cast<int>(u), img.width() - 2);
  const int y0 = std::min(static_cast<int>(v), img.height() - 2);
  const float ax = static_cast<float>(u - x0), ay = static_cast<float>(v - y0);
  const float* r0 = img.row(y0) + x0;
  const float* r1 = img.row(y0 + 1) + x0;
  return (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
}

bool inside(const Image<float>& img, double u, double v) {
  return u >= 0.0 && v >= 0.0 && u <= img.width() - 1.0 && v <= img.height() - 1.0;
}

/// The candidate camera as plain numbers (the fit's state).
struct State {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double f = 525.0, cx = 319.5, cy = 239.5;

  bool project(const Eigen::Vector3d& p, double& u, double& v) const {
    const Eigen::Vector3d q = R * p + t;
    if (!(q.z() > 1e-6)) return false;
    u = f * q.x() / q.z() + cx;
    v = f * q.y() / q.z() + cy;
    return true;
  }
  ColourCamera camera(const Intrinsics& size) const {
    ColourCamera c;
    c.intrinsics = size;
    c.intrinsics.fx = c.intrinsics.fy = f;
    c.intrinsics.cx = cx;
    c.intrinsics.cy = cy;
    c.T_colour_depth = Pose(R, t).normalized();
    return c;
  }
};

Eigen::Matrix3d exp_so3(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

double rotation_angle(const Eigen::Matrix3d& R) {
  return Eigen::AngleAxisd(R).angle();
}

/// Truncated squared-distance cost of `s` over every point (outside the image: tau^2).
struct Cost {
  double sum = 0.0;
  std::size_t points = 0, inliers = 0;
  double mean() const { return points ? sum / static_cast<double>(points) : 0.0; }
};

Cost truncated_cost(const std::vector<EdgeFrame>& frames, const State& s, double tau) {
  Cost c;
  const double tau2 = tau * tau;
  for (const EdgeFrame& fr : frames) {
    for (const Eigen::Vector3d& p : fr.points) {
      ++c.points;
      double u, v;
      if (!s.project(p, u, v) || !inside(fr.distance, u, v)) {
        c.sum += tau2;
        continue;
      }
      const double d = bilinear(fr.distance, u, v);
      if (d < tau) {
        c.sum += d * d;
        ++c.inliers;
      } else {
        c.sum += tau2;
      }
    }
  }
  return c;
}

/// The normal equations of one truncated least-squares step at `s`.
struct Normal {
  Eigen::Matrix<double, kParams, kParams> H = Eigen::Matrix<double, kParams, kParams>::Zero();
  Eigen::Matrix<double, kParams, 1> g = Eigen::Matrix<double, kParams, 1>::Zero();
  double residual_sq = 0.0;
  std::size_t inliers = 0;
};

Normal normal_equations(const std::vector<EdgeFrame>& frames, const State& s, double tau) {
  Normal n;
  Eigen::Matrix<double, 2, kParams> duv;
  for (const EdgeFrame& fr : frames) {
    for (const Eigen::Vector3d& p : fr.points) {
      const Eigen::Vector3d rp = s.R * p;
      const Eigen::Vector3d q = rp + s.t;
      if (!(q.z() > 1e-6)) continue;
      const double iz = 1.0 / q.z();
      const double xn = q.x() * iz, yn = q.y() * iz;
      const double u = s.f * xn + s.cx, v = s.f * yn + s.cy;
      if (!(u >= 1.0 && v >= 1.0 && u <= fr.distance.width() - 2.0 &&
            v <= fr.distance.height() - 2.0))
        continue;
      const double d = bilinear(fr.distance, u, v);
      if (!(d < tau)) continue;
      // The distance's gradient: central differences (the bilinear sample of the central-difference
      // image, without storing it).
      const double gx =
          0.5 * (bilinear(fr.distance, u + 1.0, v) - bilinear(fr.distance, u - 1.0, v));
      const double gy =
          0.5 * (bilinear(fr.distance, u, v + 1.0) - bilinear(fr.distance, u, v - 1.0));
      // d(u, v) / dq
      Eigen::Matrix<double, 2, 3> dq;
      dq << s.f * iz, 0.0, -s.f * xn * iz, 0.0, s.f * iz, -s.f * yn * iz;
      // q = exp(w) R p + t: dq/dw = -[R p]x
      Eigen::Matrix3d skew;
      skew << 0.0, -rp.z(), rp.y(), rp.z(), 0.0, -rp.x(), -rp.y(), rp.x(), 0.0;
      duv.block<2, 3>(0, 0) = -dq * skew;
      duv.block<2, 3>(0, 3) = dq;
      duv(0, 6) = xn;
      duv(1, 6) = yn;
      duv(0, 7) = 1.0;
      duv(1, 7) = 0.0;
      duv(0, 8) = 0.0;
      duv(1, 8) = 1.0;
      const Eigen::Matrix<double, 1, kParams> J = gx * duv.row(0) + gy * duv.row(1);
      n.H.noalias() += J.transpose() * J;
      n.g.noalias() += J.transpose() * d;
      n.residual_sq += d * d;
      ++n.inliers;
    }
  }
  return n;
}

State apply(const State& s, const Eigen::Matrix<double, kParams, 1>& dx) {
  State r = s;
  r.R = exp_so3(dx.head<3>()) * s.R;
  r.t = s.t + dx.segment<3>(3);
  r.f = s.f + dx(6);
  r.cx = s.cx + dx(7);
  r.cy = s.cy + dx(8);
  return r;
}

/// Levenberg-Marquardt on the truncated squared distance at radius `tau`.
State refine(const std::vector<EdgeFrame>& frames, State s, double tau, int iterations,
             const std::array<bool, kParams>& free) {
  double lambda = 1e-3;
  Cost cost = truncated_cost(frames, s, tau);
  for (int it = 0; it < iterations; ++it) {
    const Normal n = normal_equations(frames, s, tau);
    if (n.inliers < 10) break;
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Eigen::Matrix<double, kParams, kParams> A = n.H;
      Eigen::Matrix<double, kParams, 1> b = -n.g;
      for (int i = 0; i < kParams; ++i) {
        if (!free[i]) {
          A.row(i).setZero();
          A.col(i).setZero();
          A(i, i) = 1.0;
          b(i) = 0.0;
        } else {
          A(i, i) += lambda * std::max(n.H(i, i), 1e-12);
        }
      }
      const Eigen::Matrix<double, kParams, 1> dx = A.ldlt().solve(b);
      if (!dx.allFinite()) {
        lambda *= 10.0;
        continue;
      }
      const State trial = apply(s, dx);
      const Cost c = truncated_cost(frames, trial, tau);
      if (c.sum < cost.sum) {
        const double gain = (cost.sum - c.sum) / std::max(cost.sum, 1e-12);
        s = trial;
        cost = c;
        lambda = std::max(lambda / 3.0, 1e-7);
        improved = true;
        if (gain < 1e-7) return s;
      } else {
        lambda *= 4.0;
      }
    }
    if (!improved) break;
  }
  return s;
}

/// A coarse candidate: a shift of the whole image (as a rotation), a baseline along x, a focal.
State coarse_state(const State& nominal, double du, double dv, double tx, double focal_scale) {
  State s = nominal;
  s.f = nominal.f * focal_scale;
  const double beta = std::atan2(du, s.f), alpha = -std::atan2(dv, s.f);
  s.R = (Eigen::AngleAxisd(beta, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
  s.t = Eigen::Vector3d(tx, 0.0, 0.0);
  return s;
}

/// Mean truncated (not squared) distance over thinned points, nearest-pixel lookup.
double coarse_cost(const std::vector<EdgeFrame>& frames, const std::vector<std::vector<int>>& pick,
                   const State& s, double tau) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const EdgeFrame& fr = frames[k];
    for (int i : pick[k]) {
      ++n;
      double u, v;
      if (!s.project(fr.points[i], u, v) || !inside(fr.distance, u, v)) {
        sum += tau;
        continue;
      }
      const float d = fr.distance(static_cast<int>(u + 0.5), static_cast<int>(v + 0.5));
      sum += std::min<double>(d, tau);
    }
  }
  return n ? sum / static_cast<double>(n) : tau;
}

double percentile(std::vector<float>& values, double q) {
  if (values.empty()) return 0.0;
  const std::size_t k =
      std::min(values.size() - 1, static_cast<std::size_t>(q * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

Image<std::uint8_t> to_image(const cv::Mat& grey) {
  Image<std::uint8_t> out(grey.cols, grey.rows);
  for (int y = 0; y < grey.rows; ++y)
    std::copy(grey.ptr<std::uint8_t>(y), grey.ptr<std::uint8_t>(y) + grey.cols, out.row(y));
  return out;
}

}  // namespace

void find_depth_edges(const Image<std::uint16_t>& depth, double depth_scale,
                      const Intrinsics& depth_intrinsics, const EdgeOptions& options,
                      std::vector<Eigen::Vector3d>& points,
                      std::vector<Eigen::Vector2d>& depth_pixels) {
  points.clear();
  depth_pixels.clear();
  const int w = depth.width(), h = depth.height();
  const double to_m = 1.0 / depth_scale;
  auto z_at = [&](int x, int y) -> double {
    if (x < 0 || y < 0 || x >= w || y >= h) return 0.0;
    const std::uint16_t raw = depth(x, y);
    return (raw == 0 || raw == 65535) ? 0.0 : raw * to_m;
  };
  auto jump = [&](double zn, double zf) {
    return zf - zn > std::max(options.min_jump_m, options.min_jump_rel * zn);
  };
  std::vector<Eigen::Vector3d> all_points;
  std::vector<Eigen::Vector2d> all_pixels;
  const int b = options.border_px;
  for (int y = b; y < h - b; ++y) {
    for (int x = b; x < w - b; ++x) {
      const double z0 = z_at(x, y);
      if (z0 <= 0.0) continue;
      for (int dir = 0; dir < 2; ++dir) {
        const int dx = dir == 0 ? 1 : 0, dy = dir == 0 ? 0 : 1;
        if (x + dx >= w - b || y + dy >= h - b) continue;
        const double z1 = z_at(x + dx, y + dy);
        if (z1 <= 0.0) continue;
        // near: the pixel of the pair with the smaller depth; beyond each side, its neighbour.
        const bool first_near = z0 < z1;
        const double zn = first_near ? z0 : z1, zf = first_near ? z1 : z0;
        if (!jump(zn, zf)) continue;
        const double z_before = z_at(x - dx, y - dy), z_after = z_at(x + 2 * dx, y + 2 * dy);
        const double zn2 = first_near ? z_before : z_after, zf2 = first_near ? z_after : z_before;
        if (zn2 <= 0.0 || zf2 <= 0.0) continue;
        const double gap = zf - zn;
        if (std::abs(zn2 - zn) > 0.5 * gap || std::abs(zf2 - zf) > 0.5 * gap) continue;
        // The point is on the nearer surface: at its pixel, or on the boundary between the two.
        const bool at_near = options.placement == EdgePlacement::kNearPixel;
        const double u = at_near ? (first_near ? x : x + dx) : x + 0.5 * dx;
        const double v = at_near ? (first_near ? y : y + dy) : y + 0.5 * dy;
        all_points.push_back(depth_intrinsics.unproject(u, v, zn));
        all_pixels.emplace_back(u, v);
      }
    }
  }
  const std::size_t n = all_points.size();
  const std::size_t keep =
      options.max_points > 0
          ? std::min<std::size_t>(n, static_cast<std::size_t>(options.max_points))
          : n;
  points.reserve(keep);
  depth_pixels.reserve(keep);
  for (std::size_t k = 0; k < keep; ++k) {
    const std::size_t i = keep == n ? k : (k * n) / keep;
    points.push_back(all_points[i]);
    depth_pixels.push_back(all_pixels[i]);
  }
}

void colour_edges_from_grey(const Image<std::uint8_t>& grey, const EdgeOptions& options,
                            EdgeFrame& frame) {
  const cv::Mat src(grey.height(), grey.width(), CV_8UC1, const_cast<std::uint8_t*>(grey.data()));
  cv::Mat blurred, edges, dist;
  if (options.blur_sigma_px > 0.0)
    cv::GaussianBlur(src, blurred, cv::Size(0, 0), options.blur_sigma_px);
  else
    blurred = src;
  cv::Canny(blurred, edges, options.canny_low, options.canny_high, 3, true);
  frame.colour_edge_pixels = cv::countNonZero(edges);
  cv::Mat not_edges;
  cv::bitwise_not(edges, not_edges);
  cv::distanceTransform(not_edges, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  const int w = grey.width(), h = grey.height();
  frame.distance.resize(w, h);
  for (int y = 0; y < h; ++y)
    std::copy(dist.ptr<float>(y), dist.ptr<float>(y) + w, frame.distance.row(y));
}

EdgeFrame make_edge_frame(const Image<std::uint16_t>& depth, double depth_scale,
                          const Intrinsics& depth_intrinsics, const Image<Rgb8>& colour,
                          const EdgeOptions& options, int frame_index) {
  EdgeFrame frame;
  frame.frame = frame_index;
  find_depth_edges(depth, depth_scale, depth_intrinsics, options, frame.points, frame.depth_pixels);
  Image<std::uint8_t> grey(colour.width(), colour.height());
  for (int y = 0; y < colour.height(); ++y)
    for (int x = 0; x < colour.width(); ++x) {
      const Rgb8 c = colour(x, y);
      grey(x, y) = static_cast<std::uint8_t>(std::lround(0.299 * c.r + 0.587 * c.g + 0.114 * c.b));
    }
  colour_edges_from_grey(grey, options, frame);
  return frame;
}

namespace {

void collect_distances(const EdgeFrame& fr, const ColourCamera* camera, EdgeDistances& out,
                       std::vector<float>& d) {
  for (std::size_t i = 0; i < fr.points.size(); ++i) {
    double u = fr.depth_pixels[i].x(), v = fr.depth_pixels[i].y();
    if (camera && !camera->project(fr.points[i], u, v)) {
      ++out.outside;
      continue;
    }
    if (!inside(fr.distance, u, v)) {
      ++out.outside;
      continue;
    }
    d.push_back(bilinear(fr.distance, u, v));
  }
}

void summarise(std::vector<float>& d, EdgeDistances& out) {
  out.points = d.size();
  if (d.empty()) return;
  out.within_2px =
      static_cast<double>(std::count_if(d.begin(), d.end(), [](float x) { return x <= 2.0f; })) /
      static_cast<double>(d.size());
  out.median_px = percentile(d, 0.5);
  out.p90_px = percentile(d, 0.9);
}

}  // namespace

EdgeDistances measure_edge_distances(const std::vector<EdgeFrame>& frames,
                                     const ColourCamera* camera) {
  EdgeDistances out;
  std::vector<float> d;
  for (const EdgeFrame& fr : frames) collect_distances(fr, camera, out, d);
  summarise(d, out);
  return out;
}

EdgeDistances measure_edge_distances(const EdgeFrame& frame, const ColourCamera* camera) {
  EdgeDistances out;
  std::vector<float> d;
  collect_distances(frame, camera, out, d);
  summarise(d, out);
  return out;
}

double chance_median_px(const std::vector<EdgeFrame>& frames) {
  std::vector<float> d;
  for (const EdgeFrame& fr : frames)
    for (int y = 0; y < fr.distance.height(); y += 4)
      for (int x = 0; x < fr.distance.width(); x += 4) d.push_back(fr.distance(x, y));
  return percentile(d, 0.5);
}

FitResult fit_colour_camera(const std::vector<EdgeFrame>& frames, const ColourCamera& nominal,
                            const FitOptions& options, const Progress& progress) {
  std::size_t total = 0;
  for (const EdgeFrame& fr : frames) total += fr.points.size();
  if (total < 200)
    throw input_error("too few depth edges to register: " + std::to_string(total) + " points in " +
                      std::to_string(frames.size()) + " frames (need 200)");
  auto say = [&](const std::string& m) {
    if (progress) progress(m);
  };

  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&start] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  State nominal_state;
  nominal_state.f = nominal.intrinsics.fx;
  nominal_state.cx = nominal.intrinsics.cx;
  nominal_state.cy = nominal.intrinsics.cy;

  // Coarse search on thinned points.
  std::vector<std::vector<int>> pick(frames.size());
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const int n = static_cast<int>(frames[k].points.size());
    const int per_frame =
        std::max(20, std::min(options.coarse_points_per_frame,
                              options.coarse_points_total / static_cast<int>(frames.size())));
    const int m = std::min(n, per_frame);
    for (int i = 0; i < m; ++i)
      pick[k].push_back(static_cast<int>((static_cast<long long>(i) * n) / m));
  }
  struct Cell {
    double cost, du, dv, tx, fs;
  };
  std::vector<Cell> cells;
  const double coarse_tau = 15.0;
  const int steps =
      static_cast<int>(std::floor(options.coarse_shift_px / options.coarse_shift_step_px));
  for (double fs : options.coarse_focal_scale) {
    for (double tx : options.coarse_baseline_m) {
      for (int iy = -steps; iy <= steps; ++iy) {
        for (int ix = -steps; ix <= steps; ++ix) {
          const double du = ix * options.coarse_shift_step_px,
                       dv = iy * options.coarse_shift_step_px;
          const State s = coarse_state(nominal_state, du, dv, tx, fs);
          cells.push_back({coarse_cost(frames, pick, s, coarse_tau), du, dv, tx, fs});
        }
      }
    }
  }
  std::sort(cells.begin(), cells.end(),
            [](const Cell& a, const Cell& b) { return a.cost < b.cost; });
  std::vector<Cell> starts;
  for (const Cell& c : cells) {
    if (static_cast<int>(starts.size()) >= options.refine_candidates) break;
    bool distinct = true;
    for (const Cell& s : starts)
      if (std::abs(s.du - c.du) <= 2.0 * options.coarse_shift_step_px &&
          std::abs(s.dv - c.dv) <= 2.0 * options.coarse_shift_step_px)
        distinct = false;
    if (distinct) starts.push_back(c);
  }
  char line[256];
  std::snprintf(line, sizeof line,
                "coarse search: %zu cells, best mean distance %.2f px (shift %+.0f, %+.0f px, "
                "baseline %+.3f m, focal x%.2f), %.1f s",
                cells.size(), starts.front().cost, starts.front().du, starts.front().dv,
                starts.front().tx, starts.front().fs, elapsed());
  say(line);

  std::array<bool, kParams> free{};
  for (int i = 0; i < 7; ++i) free[i] = true;
  free[7] = free[8] = options.fit_principal_point;

  const double last_tau = options.truncation_px.empty() ? 3.0 : options.truncation_px.back();
  State best;
  double best_cost = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < starts.size(); ++k) {
    State s = coarse_state(nominal_state, starts[k].du, starts[k].dv, starts[k].tx, starts[k].fs);
    for (double tau : options.truncation_px)
      s = refine(frames, s, tau, options.iterations_per_stage, free);
    const Cost c = truncated_cost(frames, s, last_tau);
    std::snprintf(line, sizeof line,
                  "refined start %zu/%zu: mean truncated squared distance %.3f px^2, %zu/%zu "
                  "points within %.1f px, %.1f s",
                  k + 1, starts.size(), c.mean(), c.inliers, c.points, last_tau, elapsed());
    say(line);
    if (c.mean() < best_cost) {
      best_cost = c.mean();
      best = s;
    }
  }

  FitResult result;
  result.camera = best.camera(nominal.intrinsics);
  result.coarse_cost = starts.front().cost;
  const Cost c = truncated_cost(frames, best, last_tau);
  result.final_cost = c.mean();
  result.inliers = c.inliers;
  result.points = c.points;

  // Conditioning and formal uncertainties from the last stage's normal equations.
  const Normal n = normal_equations(frames, best, last_tau);
  std::vector<int> idx;
  for (int i = 0; i < kParams; ++i)
    if (free[i]) idx.push_back(i);
  const int m = static_cast<int>(idx.size());
  Eigen::MatrixXd H(m, m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) H(a, b) = n.H(idx[a], idx[b]);
  Eigen::VectorXd scale(m);
  for (int a = 0; a < m; ++a) scale(a) = 1.0 / std::sqrt(std::max(H(a, a), 1e-300));
  const Eigen::MatrixXd C = scale.asDiagonal() * H * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(C);
  const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
  result.condition = lo > 0.0 ? hi / lo : std::numeric_limits<double>::infinity();
  if (n.inliers < 100 || !(result.condition < 1e8)) {
    throw Error(ExitCode::kFailure,
                "colour registration is degenerate: the depth edges do not constrain every "
                "parameter (condition number " +
                    std::to_string(result.condition) + ", " + std::to_string(n.inliers) +
                    " inlier points); use more frames or a scene "
                    "with edges at several depths");
  }
  const double dof = std::max<double>(1.0, static_cast<double>(n.inliers) - m);
  const double s2 = n.residual_sq / dof;
  const Eigen::MatrixXd cov = H.ldlt().solve(Eigen::MatrixXd::Identity(m, m)) * s2;
  for (int a = 0; a < m; ++a) result.sigma[idx[a]] = std::sqrt(std::max(cov(a, a), 0.0));

  // Plausibility: a fit that ran away is no calibration.
  const double fscale = best.f / nominal_state.f;
  const double angle_deg = rotation_angle(best.R) * 180.0 / kPi;
  if (!(fscale > 0.75 && fscale < 1.0 / 0.75) || !(best.t.norm() < 0.2) || !(angle_deg < 15.0)) {
    std::snprintf(line, sizeof line,
                  "colour registration did not converge to a plausible camera (focal %.1f px, "
                  "translation %.3f m, rotation %.2f deg)",
                  best.f, best.t.norm(), angle_deg);
    throw Error(ExitCode::kFailure, line);
  }
  return result;
}

RecordingResult register_recording(const std::string& folder, const RecordingOptions& options,
                                   const Progress& progress) {
  namespace fs = std::filesystem;
  if (options.max_frames < 1) throw usage_error("--frames must be at least 1");
  if (options.step < 1) throw usage_error("--step must be at least 1");
  auto say = [&](const std::string& m) {
    if (progress) progress(m);
  };
  const fs::path dir(folder);
  if (!fs::is_directory(dir)) throw input_error(folder + ": not a folder");
  const fs::path depth_list = dir / "depth.txt", rgb_list = dir / "rgb.txt";
  if (!fs::exists(depth_list))
    throw input_error(depth_list.string() + ": not found (not a TUM-layout recording)");
  if (!fs::exists(rgb_list))
    throw input_error(rgb_list.string() + ": not found (the recording has no colour stream)");

  RecordingResult result;
  const fs::path camera_path = dir / "camera.json";
  CameraInfo info = fs::exists(camera_path) ? read_camera_json(camera_path.string(), 640, 480)
                                            : default_camera_for_folder(folder);
  result.depth_intrinsics = info.intrinsics;
  result.depth_scale = info.depth_scale;
  result.depth_calibration_origin = info.origin;

  const std::vector<TumListEntry> depth_entries = read_tum_list(depth_list.string());
  std::vector<TumListEntry> rgb_entries = read_tum_list(rgb_list.string());
  if (depth_entries.empty()) throw input_error(depth_list.string() + ": lists no frames");
  if (rgb_entries.empty()) throw input_error(rgb_list.string() + ": lists no frames");
  std::stable_sort(
      rgb_entries.begin(), rgb_entries.end(),
      [](const TumListEntry& a, const TumListEntry& b) { return a.timestamp_s < b.timestamp_s; });

  auto skip = [&](const std::string& message) {
    ++result.skipped;
    if (result.first_skip.empty()) result.first_skip = message;
    if (options.verbose) say("skipped: " + message);
  };

  const auto start = std::chrono::steady_clock::now();
  auto seconds_since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  std::vector<EdgeFrame> frames;
  int colour_w = 0, colour_h = 0;
  Image<std::uint16_t> depth;
  int attempted = 0;
  const int wanted = std::min<long long>(
      options.max_frames,
      (static_cast<long long>(depth_entries.size()) + options.step - 1) / options.step);
  for (std::size_t i = 0; i < depth_entries.size() && attempted < options.max_frames;
       i += static_cast<std::size_t>(options.step)) {
    ++attempted;
    if (attempted % 10 == 0 || attempted == wanted)
      say("reading pairs: " + std::to_string(attempted) + "/" + std::to_string(wanted));
    const TumListEntry& de = depth_entries[i];
    // The colour frame nearest in time (within 20 ms).
    auto it = std::lower_bound(rgb_entries.begin(), rgb_entries.end(), de.timestamp_s,
                               [](const TumListEntry& e, double t) { return e.timestamp_s < t; });
    const TumListEntry* match = nullptr;
    double best_dt = 0.02;
    for (auto c : {it, it == rgb_entries.begin() ? it : it - 1}) {
      if (c == rgb_entries.end()) continue;
      const double dt = std::abs(c->timestamp_s - de.timestamp_s);
      if (dt <= best_dt) {
        best_dt = dt;
        match = &*c;
      }
    }
    const std::string depth_path = (dir / de.path).string();
    if (!match) {
      skip(depth_list.string() + ":" + std::to_string(de.line) +
           ": no colour frame within 20 ms in rgb.txt");
      continue;
    }
    const Status st = read_grey16_png(depth_path, depth, static_cast<std::uint64_t>(i));
    if (!st.is_ok()) {
      skip(st.message());
      continue;
    }
    if (depth.width() != info.intrinsics.width || depth.height() != info.intrinsics.height) {
      skip(depth_path + ": " + std::to_string(depth.width()) + "x" +
           std::to_string(depth.height()) + " but the calibration is " +
           std::to_string(info.intrinsics.width) + "x" + std::to_string(info.intrinsics.height));
      continue;
    }
    const std::string colour_path = (dir / match->path).string();
    const cv::Mat bgr = cv::imread(colour_path, cv::IMREAD_GRAYSCALE);
    if (bgr.empty() || bgr.cols < 8 || bgr.rows < 8) {
      skip(colour_path + ": cannot read the colour image");
      continue;
    }
    if (colour_w == 0) {
      colour_w = bgr.cols;
      colour_h = bgr.rows;
    } else if (bgr.cols != colour_w || bgr.rows != colour_h) {
      skip(colour_path + ": " + std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows) +
           " but the first colour image is " + std::to_string(colour_w) + "x" +
           std::to_string(colour_h));
      continue;
    }
    EdgeFrame frame;
    frame.frame = static_cast<int>(i);
    find_depth_edges(depth, info.depth_scale, info.intrinsics, options.edges, frame.points,
                     frame.depth_pixels);
    colour_edges_from_grey(to_image(bgr), options.edges, frame);
    if (frame.points.size() < 20) {
      skip(depth_path + ": too few depth edges (" + std::to_string(frame.points.size()) + ")");
      continue;
    }
    if (frame.colour_edge_pixels < 100) {
      skip(colour_path + ": too few colour edges (" + std::to_string(frame.colour_edge_pixels) +
           ")");
      continue;
    }
    if (options.verbose) {
      char line[160];
      std::snprintf(line, sizeof line, "frame %d: %zu depth-edge points, %d colour edge pixels",
                    frame.frame, frame.points.size(), frame.colour_edge_pixels);
      say(line);
    }
    frames.push_back(std::move(frame));
  }
  if (frames.empty())
    throw input_error(folder + ": no usable depth/colour pair among " + std::to_string(attempted) +
                      " read" +
                      (result.first_skip.empty() ? "" : " (first: " + result.first_skip + ")"));

  result.read_s = seconds_since(start);
  // Every other usable pair fits; the rest measure (a single pair does both).
  std::vector<EdgeFrame> fit_set, eval_set;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    if (k % 2 == 0 || frames.size() == 1) {
      result.fit_frames.push_back(frames[k].frame);
      fit_set.push_back(std::move(frames[k]));
    } else {
      result.eval_frames.push_back(frames[k].frame);
      eval_set.push_back(std::move(frames[k]));
    }
  }
  result.held_out = !eval_set.empty();
  const ColourCamera nominal = ColourCamera::nominal(colour_w, colour_h);
  const auto fit_start = std::chrono::steady_clock::now();
  try {
    result.fit = fit_colour_camera(fit_set, nominal, options.fit, progress);
  } catch (const Error& e) {
    if (e.code() == ExitCode::kBadInput) throw input_error(folder + ": " + e.what());
    throw;
  }
  result.fit_s = seconds_since(fit_start);
  const std::vector<EdgeFrame>& measured = result.held_out ? eval_set : fit_set;
  if (!result.held_out) result.eval_frames = result.fit_frames;
  result.before = measure_edge_distances(measured, nullptr);
  result.after = measure_edge_distances(measured, &result.fit.camera);
  for (const EdgeFrame& fr : measured) {
    result.before_per_frame.push_back(measure_edge_distances(fr, nullptr));
    result.after_per_frame.push_back(measure_edge_distances(fr, &result.fit.camera));
  }
  result.chance_median_px = chance_median_px(measured);
  std::vector<float> offsets;
  for (const EdgeFrame& fr : measured)
    for (std::size_t i = 0; i < fr.points.size(); ++i) {
      double u, v;
      if (result.fit.camera.project(fr.points[i], u, v))
        offsets.push_back(static_cast<float>((Eigen::Vector2d(u, v) - fr.depth_pixels[i]).norm()));
    }
  result.offset_median_px = percentile(offsets, 0.5);
  result.offset_p90_px = percentile(offsets, 0.9);
  return result;
}

}  // namespace aoscan::colour_registration
