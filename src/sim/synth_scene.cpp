/// @file synth_scene.cpp
/// @brief Analytic box-and-sphere scenes: ray casting, distances, meshes and the built-in scenes.
#include "sim/synth_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <utility>

#include "core/status.h"

namespace aoscan {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Largest allowed deviation of a tessellated sphere from the true sphere (metres).
constexpr double kSphereToleranceM = 1e-4;
constexpr int kMaxSphereLevels = 7;

/// The line through the ray meets the box for t in [t_near, t_far]; `near_axis` / `far_axis` name
/// the slab whose plane bounds the interval. Returns false when the line misses the box.
inline bool slab_interval(const SceneBox& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                          const Eigen::Vector3d& inv_d, double* t_near, int* near_axis,
                          double* t_far, int* far_axis) {
  double lo = -kInf;
  double hi = kInf;
  int lo_axis = -1;
  int hi_axis = -1;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < box.min[a] || o[a] > box.max[a]) return false;
      continue;
    }
    double t0 = (box.min[a] - o[a]) * inv_d[a];
    double t1 = (box.max[a] - o[a]) * inv_d[a];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > lo) {
      lo = t0;
      lo_axis = a;
    }
    if (t1 < hi) {
      hi = t1;
      hi_axis = a;
    }
  }
  if (lo > hi) return false;
  *t_near = lo;
  *near_axis = lo_axis;
  *t_far = hi;
  *far_axis = hi_axis;
  return true;
}

/// Nearest parameter in [t_min, t_max] where the ray crosses the sphere's surface.
inline bool sphere_crossing(const SceneSphere& s, const Eigen::Vector3d& o,
                            const Eigen::Vector3d& d, double t_min, double t_max, double* t) {
  const Eigen::Vector3d oc = o - s.centre;
  const double b = oc.dot(d);
  // Squared distance of the centre from the line, computed without cancellation.
  const Eigen::Vector3d perp = oc - b * d;
  const double disc = s.radius * s.radius - perp.squaredNorm();
  if (disc < 0.0) return false;
  const double root = std::sqrt(disc);
  const double t0 = -b - root;
  const double t1 = -b + root;
  if (t0 >= t_min && t0 <= t_max) {
    *t = t0;
    return true;
  }
  if (t1 >= t_min && t1 <= t_max) {
    *t = t1;
    return true;
  }
  return false;
}

inline Eigen::Vector3d safe_inverse(const Eigen::Vector3d& d) {
  return {d.x() != 0.0 ? 1.0 / d.x() : kInf, d.y() != 0.0 ? 1.0 / d.y() : kInf,
          d.z() != 0.0 ? 1.0 / d.z() : kInf};
}

double box_signed_distance(const SceneBox& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d centre = 0.5 * (box.min + box.max);
  const Eigen::Vector3d half = 0.5 * (box.max - box.min);
  const Eigen::Vector3d q = (p - centre).cwiseAbs() - half;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double sphere_signed_distance(const SceneSphere& s, const Eigen::Vector3d& p) {
  return (p - s.centre).norm() - s.radius;
}

void append_box(const SceneBox& box, TriangleMesh* mesh) {
  for (int a = 0; a < 3; ++a) {
    const int u = (a + 1) % 3;
    const int v = (a + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      const double coord = side == 0 ? box.min[a] : box.max[a];
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[a] = side == 0 ? -1.0f : 1.0f;
      const int base = static_cast<int>(mesh->vertices.size());
      // Counter-clockwise seen from +a (e_u x e_v = e_a).
      const std::array<std::pair<double, double>, 4> uv = {{{box.min[u], box.min[v]},
                                                            {box.max[u], box.min[v]},
                                                            {box.max[u], box.max[v]},
                                                            {box.min[u], box.max[v]}}};
      for (const auto& [cu, cv] : uv) {
        Eigen::Vector3d p;
        p[a] = coord;
        p[u] = cu;
        p[v] = cv;
        mesh->vertices.push_back(p.cast<float>());
        mesh->normals.push_back(normal);
      }
      if (side == 1) {
        mesh->faces.emplace_back(base, base + 1, base + 2);
        mesh->faces.emplace_back(base, base + 2, base + 3);
      } else {
        mesh->faces.emplace_back(base, base + 2, base + 1);
        mesh->faces.emplace_back(base, base + 3, base + 2);
      }
    }
  }
}

/// Unit icosphere: vertices on the unit sphere, faces counter-clockwise seen from outside.
struct UnitSphereMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;
};

UnitSphereMesh icosahedron() {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  UnitSphereMesh m;
  m.vertices = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
                {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
                {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  for (auto& v : m.vertices) v.normalize();
  m.faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
             {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
             {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  return m;
}

UnitSphereMesh subdivide(const UnitSphereMesh& in) {
  UnitSphereMesh out;
  out.vertices = in.vertices;
  out.faces.reserve(in.faces.size() * 4);
  std::map<std::pair<int, int>, int> midpoints;
  auto midpoint = [&](int i, int j) {
    const std::pair<int, int> key = std::minmax(i, j);
    const auto it = midpoints.find(key);
    if (it != midpoints.end()) return it->second;
    const int index = static_cast<int>(out.vertices.size());
    out.vertices.push_back((in.vertices[i] + in.vertices[j]).normalized());
    midpoints.emplace(key, index);
    return index;
  };
  for (const auto& f : in.faces) {
    const int ab = midpoint(f[0], f[1]);
    const int bc = midpoint(f[1], f[2]);
    const int ca = midpoint(f[2], f[0]);
    out.faces.emplace_back(f[0], ab, ca);
    out.faces.emplace_back(f[1], bc, ab);
    out.faces.emplace_back(f[2], ca, bc);
    out.faces.emplace_back(ab, bc, ca);
  }
  return out;
}

/// Largest distance between a flat face and the unit sphere (1 - distance of the face's plane
/// from the centre; the nearest point of each face's plane lies inside these acute faces).
double max_deviation(const UnitSphereMesh& m) {
  double worst = 0.0;
  for (const auto& f : m.faces) {
    const Eigen::Vector3d& a = m.vertices[f[0]];
    const Eigen::Vector3d n = (m.vertices[f[1]] - a).cross(m.vertices[f[2]] - a).normalized();
    worst = std::max(worst, 1.0 - std::abs(n.dot(a)));
  }
  return worst;
}

void append_sphere(const SceneSphere& s, TriangleMesh* mesh) {
  UnitSphereMesh m = icosahedron();
  for (int level = 0; level < kMaxSphereLevels && max_deviation(m) * s.radius >= kSphereToleranceM;
       ++level) {
    m = subdivide(m);
  }
  const int base = static_cast<int>(mesh->vertices.size());
  for (const auto& v : m.vertices) {
    mesh->vertices.push_back((s.centre + s.radius * v).cast<float>());
    mesh->normals.push_back(v.cast<float>());
  }
  for (const auto& f : m.faces) mesh->faces.emplace_back(f + Eigen::Vector3i::Constant(base));
}

template <class BoxAt, class SphereAt>
bool nearest_hit(const Ray& ray, double t_min, double t_max, int box_count, BoxAt box_at,
                 int sphere_count, SphereAt sphere_at, Hit* hit, const SceneBox** hit_box,
                 const SceneSphere** hit_sphere) {
  const Eigen::Vector3d& o = ray.origin;
  const Eigen::Vector3d& d = ray.direction;
  const Eigen::Vector3d inv_d = safe_inverse(d);
  double best = t_max;
  bool found = false;
  int best_axis = -1;
  double best_sign = 0.0;
  const SceneSphere* best_sphere = nullptr;
  const SceneBox* best_box = nullptr;
  for (int i = 0; i < box_count; ++i) {
    double t_near, t_far;
    int near_axis, far_axis;
    if (!slab_interval(box_at(i), o, d, inv_d, &t_near, &near_axis, &t_far, &far_axis)) continue;
    if (t_near >= t_min) {
      if (t_near <= best) {
        best = t_near;
        best_axis = near_axis;
        best_sign = d[near_axis] > 0.0 ? -1.0 : 1.0;  // entering: against the ray
        best_sphere = nullptr;
        best_box = &box_at(i);
        found = true;
      }
    } else if (t_far >= t_min && t_far <= best) {
      best = t_far;
      best_axis = far_axis;
      best_sign = d[far_axis] > 0.0 ? 1.0 : -1.0;  // leaving: along the ray
      best_sphere = nullptr;
      best_box = &box_at(i);
      found = true;
    }
  }
  for (int i = 0; i < sphere_count; ++i) {
    const SceneSphere& s = sphere_at(i);
    double t;
    if (sphere_crossing(s, o, d, t_min, best, &t)) {
      best = t;
      best_sphere = &s;
      found = true;
    }
  }
  if (!found) return false;
  *hit_box = best_sphere != nullptr ? nullptr : best_box;
  *hit_sphere = best_sphere;
  if (hit != nullptr) {
    hit->t = best;
    if (best_sphere != nullptr) {
      hit->normal = (o + best * d - best_sphere->centre).normalized();
    } else {
      hit->normal = Eigen::Vector3d::Zero();
      hit->normal[best_axis] = best_sign;
    }
  }
  return true;
}

}  // namespace

void AnalyticScene::add_box(const Eigen::Vector3d& min_corner, const Eigen::Vector3d& max_corner) {
  if (!min_corner.allFinite() || !max_corner.allFinite() ||
      !(min_corner.array() < max_corner.array()).all()) {
    throw usage_error("analytic scene '" + name_ + "': a box needs finite corners with min < max");
  }
  boxes_.push_back({min_corner, max_corner});
}

void AnalyticScene::add_sphere(const Eigen::Vector3d& centre, double radius) {
  if (!centre.allFinite() || !std::isfinite(radius) || radius <= 0.0) {
    throw usage_error("analytic scene '" + name_ +
                      "': a sphere needs a finite centre and radius > 0");
  }
  spheres_.push_back({centre, radius});
}

void AnalyticScene::add_table(const Eigen::Vector2d& centre_xy, const Eigen::Vector3d& top_size,
                              double height, double leg_side, double leg_inset) {
  const double x0 = centre_xy.x() - 0.5 * top_size.x();
  const double x1 = centre_xy.x() + 0.5 * top_size.x();
  const double y0 = centre_xy.y() - 0.5 * top_size.y();
  const double y1 = centre_xy.y() + 0.5 * top_size.y();
  const double underside = height - top_size.z();
  add_box({x0, y0, underside}, {x1, y1, height});
  for (const double lx : {x0 + leg_inset, x1 - leg_inset - leg_side}) {
    for (const double ly : {y0 + leg_inset, y1 - leg_inset - leg_side}) {
      add_box({lx, ly, 0.0}, {lx + leg_side, ly + leg_side, underside});
    }
  }
}

bool AnalyticScene::intersect(const Ray& ray, double t_min, double t_max, Hit* hit) const {
  const SceneBox* box = nullptr;
  const SceneSphere* sphere = nullptr;
  const bool found = nearest_hit(
      ray, t_min, t_max, static_cast<int>(boxes_.size()),
      [&](int i) -> const SceneBox& { return boxes_[i]; }, static_cast<int>(spheres_.size()),
      [&](int i) -> const SceneSphere& { return spheres_[i]; }, hit, &box, &sphere);
  if (found && hit != nullptr) hit->primitive = primitive_index(box, sphere);
  return found;
}

bool AnalyticScene::intersect(const Ray& ray, double t_min, double t_max,
                              const PrimitiveSubset& subset, Hit* hit) const {
  const SceneBox* box = nullptr;
  const SceneSphere* sphere = nullptr;
  const bool found = nearest_hit(
      ray, t_min, t_max, subset.box_count,
      [&](int i) -> const SceneBox& { return boxes_[subset.boxes[i]]; }, subset.sphere_count,
      [&](int i) -> const SceneSphere& { return spheres_[subset.spheres[i]]; }, hit, &box,
      &sphere);
  if (found && hit != nullptr) hit->primitive = primitive_index(box, sphere);
  return found;
}

int AnalyticScene::primitive_index(const SceneBox* box, const SceneSphere* sphere) const {
  return box != nullptr ? static_cast<int>(box - boxes_.data())
                        : static_cast<int>(boxes_.size()) + static_cast<int>(sphere - spheres_.data());
}

Rgb8 AnalyticScene::colour(int primitive) const {
  // Saturated and pale colours in turn, far apart in hue: neighbouring primitives differ.
  static constexpr Rgb8 kPalette[] = {
      {214, 196, 160}, {70, 110, 200},  {200, 60, 50},   {90, 170, 90},  {230, 200, 60},
      {150, 80, 170},  {60, 180, 190},  {240, 140, 60},  {120, 120, 120}, {190, 220, 240},
      {110, 70, 40},   {230, 120, 170}};
  constexpr int kColours = static_cast<int>(sizeof kPalette / sizeof kPalette[0]);
  if (primitive < 0) return Rgb8{};
  return kPalette[primitive % kColours];
}

bool AnalyticScene::occluded(const Ray& ray, double t_min, double t_max) const {
  const Eigen::Vector3d& o = ray.origin;
  const Eigen::Vector3d& d = ray.direction;
  const Eigen::Vector3d inv_d = safe_inverse(d);
  for (const SceneBox& box : boxes_) {
    double t_near, t_far;
    int near_axis, far_axis;
    if (!slab_interval(box, o, d, inv_d, &t_near, &near_axis, &t_far, &far_axis)) continue;
    if ((t_near >= t_min && t_near <= t_max) ||
        (t_near < t_min && t_far >= t_min && t_far <= t_max))
      return true;
  }
  for (const SceneSphere& s : spheres_) {
    double t;
    if (sphere_crossing(s, o, d, t_min, t_max, &t)) return true;
  }
  return false;
}

double AnalyticScene::distance(const Eigen::Vector3d& p) const {
  double best = kInf;
  for (const SceneBox& box : boxes_) best = std::min(best, std::abs(box_signed_distance(box, p)));
  for (const SceneSphere& s : spheres_)
    best = std::min(best, std::abs(sphere_signed_distance(s, p)));
  return best;
}

double AnalyticScene::signed_distance(const Eigen::Vector3d& p) const {
  double best = kInf;
  for (const SceneBox& box : boxes_) best = std::min(best, box_signed_distance(box, p));
  for (const SceneSphere& s : spheres_) best = std::min(best, sphere_signed_distance(s, p));
  return best;
}

std::optional<SurfacePoint> AnalyticScene::nearest_surface_point(const Eigen::Vector3d& p,
                                                                 double max_distance_m) const {
  // How far above a candidate the space must be free of solids: far below any feature of a scene,
  // far above the rounding of coordinates of a few metres.
  constexpr double kProbeM = 1e-7;
  std::optional<SurfacePoint> best;
  double best_distance = max_distance_m;
  int primitive = 0;  // of the candidates considered next
  const auto consider = [&](const Eigen::Vector3d& q, const Eigen::Vector3d& normal) {
    const double d = (q - p).norm();
    if (!(d <= best_distance) || (best && d == best_distance)) return;
    // Hidden against another solid: the probe lies kProbeM deep in it. At the line where two faces
    // meet the probe reads 0 up to rounding.
    if (signed_distance(q + kProbeM * normal) < -0.5 * kProbeM) return;
    best = SurfacePoint{q, normal, primitive};
    best_distance = d;
  };
  for (const SceneBox& box : boxes_) {
    const Eigen::Vector3d clamped = p.cwiseMax(box.min).cwiseMin(box.max);
    for (int a = 0; a < 3; ++a) {
      for (int side = 0; side < 2; ++side) {
        Eigen::Vector3d q = clamped;
        q[a] = side == 0 ? box.min[a] : box.max[a];
        Eigen::Vector3d normal = Eigen::Vector3d::Zero();
        normal[a] = side == 0 ? -1.0 : 1.0;
        consider(q, normal);
      }
    }
    ++primitive;
  }
  for (const SceneSphere& s : spheres_) {
    const Eigen::Vector3d v = p - s.centre;
    const double len = v.norm();
    const Eigen::Vector3d normal = len > 0.0 ? Eigen::Vector3d(v / len) : Eigen::Vector3d::UnitZ();
    consider(s.centre + s.radius * normal, normal);
    ++primitive;
  }
  return best;
}

TriangleMesh AnalyticScene::to_mesh() const {
  TriangleMesh mesh;
  for (const SceneBox& box : boxes_) append_box(box, &mesh);
  for (const SceneSphere& s : spheres_) append_sphere(s, &mesh);
  return mesh;
}

Eigen::AlignedBox3d AnalyticScene::bounds() const {
  Eigen::AlignedBox3d b;
  for (const SceneBox& box : boxes_) {
    b.extend(box.min);
    b.extend(box.max);
  }
  for (const SceneSphere& s : spheres_) {
    b.extend(s.centre - Eigen::Vector3d::Constant(s.radius));
    b.extend(s.centre + Eigen::Vector3d::Constant(s.radius));
  }
  return b;
}

std::vector<std::string> AnalyticScene::names() {
  return {"corner", "room", "plane"};
}

AnalyticScene AnalyticScene::make(const std::string& name) {
  AnalyticScene scene(name);
  const Eigen::Vector3d table_top(1.0, 0.6, 0.04);
  constexpr double kTableHeight = 0.72;
  constexpr double kLegSide = 0.04;
  constexpr double kLegInset = 0.03;
  if (name == "corner") {
    // Floor and two 4 m walls meeting at the z axis; the open space is x > 0, y > 0.
    scene.add_box({-0.1, -0.1, -0.1}, {4.0, 4.0, 0.0});
    scene.add_box({-0.1, 0.0, 0.0}, {0.0, 4.0, 2.7});    // wall x = 0, facing +x
    scene.add_box({-0.1, -0.1, 0.0}, {4.0, 0.0, 2.7});   // wall y = 0, facing +y
    scene.add_box({0.0, 0.0, 0.0}, {0.25, 0.25, 0.25});  // small cube in the corner
    scene.add_box({0.0, 1.6, 0.0}, {0.5, 2.3, 0.8});     // cabinet against wall x = 0
    scene.add_box({1.8, 0.0, 0.0}, {2.4, 0.4, 0.5});     // crate against wall y = 0
    scene.add_table({0.95, 0.9}, table_top, kTableHeight, kLegSide, kLegInset);
    scene.add_sphere({1.75, 1.05, 0.2}, 0.2);  // resting on the floor
  } else if (name == "room") {
    // Closed 4 x 4 x 2.6 m room, interior [0, 4] x [0, 4] x [0, 2.6].
    scene.add_box({-0.1, -0.1, -0.1}, {4.1, 4.1, 0.0});  // floor
    scene.add_box({-0.1, -0.1, 2.6}, {4.1, 4.1, 2.7});   // ceiling
    scene.add_box({-0.1, 0.0, 0.0}, {0.0, 4.0, 2.6});    // wall x = 0
    scene.add_box({4.0, 0.0, 0.0}, {4.1, 4.0, 2.6});     // wall x = 4
    scene.add_box({-0.1, -0.1, 0.0}, {4.1, 0.0, 2.6});   // wall y = 0
    scene.add_box({-0.1, 4.0, 0.0}, {4.1, 4.1, 2.6});    // wall y = 4
    scene.add_box({3.3, 3.0, 0.0}, {4.0, 4.0, 1.0});     // cabinet in a corner
    scene.add_box({2.5, 0.0, 0.0}, {3.1, 0.45, 0.45});   // crate against wall y = 0
    scene.add_box({0.0, 0.6, 0.0}, {0.5, 1.4, 0.9});     // sideboard against wall x = 0
    scene.add_table({1.0, 3.2}, table_top, kTableHeight, kLegSide, kLegInset);
    scene.add_sphere({3.0, 2.2, 0.2}, 0.2);                 // on the floor
    scene.add_sphere({1.2, 3.2, kTableHeight + 0.1}, 0.1);  // on the table top
  } else if (name == "plane") {
    // One 20 x 20 m wall whose front face is the plane y = 0, facing -y.
    scene.add_box({-10.0, 0.0, -10.0}, {10.0, 0.2, 10.0});
  } else {
    std::string valid;
    for (const auto& n : names()) valid += (valid.empty() ? "" : ", ") + n;
    throw usage_error("unknown synthetic scene '" + name + "' (valid: " + valid + ")");
  }
  return scene;
}

}  // namespace aoscan
