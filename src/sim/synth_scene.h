/// @file synth_scene.h
/// @brief Analytic scenes (unions of axis-aligned boxes and spheres) with exact ray casting, exact
/// distances and a triangle mesh: the ground truth of the synthetic `synth:` source.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/colour.h"
#include "core/mesh.h"

namespace aoscan {

/// A ray in the scene's world frame: points origin + t * direction, t in metres (direction unit).
struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

/// The nearest intersection of a ray: distance t along the ray (metres) and the outward unit normal
/// of the surface that was hit (world frame). A ray that starts inside a primitive hits the
/// primitive's boundary from inside; the normal is still the outward one.
struct Hit {
  double t = 0.0;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int primitive = -1;  ///< the primitive hit (AnalyticScene::colour())
};

/// A solid axis-aligned box [min, max] (world frame, metres).
struct SceneBox {
  Eigen::Vector3d min;
  Eigen::Vector3d max;
};

/// A solid sphere (world frame, metres).
struct SceneSphere {
  Eigen::Vector3d centre;
  double radius;
};

/// A point of a scene's surface and the outward unit normal there (world frame, metres).
struct SurfacePoint {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int primitive = -1;  ///< the primitive whose surface it is (AnalyticScene::colour())
};

/// Indices of some of a scene's primitives (e.g. those a view frustum can reach), ascending.
struct PrimitiveSubset {
  const int* boxes = nullptr;
  int box_count = 0;
  const int* spheres = nullptr;
  int sphere_count = 0;
};

/// A union of solid primitives in a world frame with z up, metres; the built-in scenes have their
/// floor at z = 0. The built-in scenes' primitives touch but never overlap, so the union's surface
/// is the union of the primitives' surfaces minus the touching patches (which are hidden).
class AnalyticScene {
 public:
  AnalyticScene() = default;
  explicit AnalyticScene(std::string name) : name_(std::move(name)) {}

  /// Adds a box with corners `min_corner` < `max_corner` (each axis); throws usage_error otherwise.
  void add_box(const Eigen::Vector3d& min_corner, const Eigen::Vector3d& max_corner);
  /// Adds a sphere of radius > 0 (metres); throws usage_error otherwise.
  void add_sphere(const Eigen::Vector3d& centre, double radius);
  /// A table: a top slab of `top_size` (x, y, thickness) whose upper surface is at `height`,
  /// centred at (centre_xy, .) and standing on four square legs of side `leg_side` at its corners,
  /// inset by `leg_inset`, resting on z = 0. Five boxes that touch but do not overlap.
  void add_table(const Eigen::Vector2d& centre_xy, const Eigen::Vector3d& top_size, double height,
                 double leg_side, double leg_inset);

  /// Nearest hit with t in [t_min, t_max] (metres along the unit ray direction); exact slab test
  /// for boxes, quadratic for spheres. Returns false on a miss; `hit` may be null.
  bool intersect(const Ray& ray, double t_min, double t_max, Hit* hit) const;
  /// intersect() over `subset` only. When the subset holds every primitive the ray can hit in
  /// [t_min, t_max], the result is bit-identical to intersect() (same order, same arithmetic).
  bool intersect(const Ray& ray, double t_min, double t_max, const PrimitiveSubset& subset,
                 Hit* hit) const;
  /// True when any surface is hit with t in [t_min, t_max] (cheaper than intersect: any hit).
  bool occluded(const Ray& ray, double t_min, double t_max) const;

  /// Unsigned distance (metres) from world point `p` to the nearest primitive surface. Exact for
  /// the union's surface when p is outside every primitive or primitives do not overlap.
  double distance(const Eigen::Vector3d& p) const;
  /// Signed distance (metres): negative inside a primitive (min over primitives of their signed
  /// distances; exact outside the solids). +infinity for an empty scene.
  double signed_distance(const Eigen::Vector3d& p) const;
  /// The point of the union's surface nearest to `p` (inside or outside the solids), with its
  /// outward normal, when it lies within max_distance_m; nullopt otherwise. Candidates are the
  /// nearest point of every box face (clamped to the face) with the face's normal and of every
  /// sphere; a candidate counts when the space just above it is not inside a solid (a face hidden
  /// against a touching primitive is not surface; a point on the line where two faces meet is).
  /// Ties go to the candidate met first: boxes before spheres, in the order they were added, faces
  /// -x, +x, -y, +y, -z, +z. Exact, unlike a projection along the gradient of signed_distance(),
  /// which inside the touching solids leads to their hidden faces.
  std::optional<SurfacePoint> nearest_surface_point(const Eigen::Vector3d& p,
                                                    double max_distance_m) const;

  /// The surface as triangles (metres, world frame) with outward per-vertex normals, counter-
  /// clockwise seen from outside. Boxes: 2 triangles per face, 4 vertices per face. Spheres:
  /// subdivided icospheres deviating < 0.1 mm from the true sphere (up to 7 subdivision levels,
  /// enough for radii up to ~3 m). Touching primitives keep their hidden, coincident faces.
  TriangleMesh to_mesh() const;

  /// The colour of primitive `primitive` (boxes are 0 .. boxes().size() - 1 in the order they
  /// were added, then the spheres): every primitive is one flat colour of a fixed palette, so
  /// neighbouring primitives differ. The synthetic colour camera's ground truth.
  Rgb8 colour(int primitive) const;

  /// Bounding box of all primitives (empty box for an empty scene).
  Eigen::AlignedBox3d bounds() const;

  const std::string& name() const { return name_; }
  const std::vector<SceneBox>& boxes() const { return boxes_; }
  const std::vector<SceneSphere>& spheres() const { return spheres_; }

  /// A built-in scene (see names()); throws usage_error naming the scene and the valid names
  /// otherwise. World frame: metres, z up, floor at z = 0.
  /// - `corner`: floor [-0.1, 4]^2 and two 2.7 m walls in the planes x = 0 and y = 0; a 0.25 m cube
  ///   in the corner, a cabinet against x = 0, a crate against y = 0, a 1.0 x 0.6 m table (top
  ///   surface 0.72 m, 4 cm legs) and a sphere of radius 0.2 m resting on the floor. Open for the
  ///   camera in x, y > 0.
  /// - `room`: closed room, interior [0, 4] x [0, 4] x [0, 2.6], with a cabinet, a crate, a
  ///   sideboard, a table with a 0.1 m ball on it and a 0.2 m ball on the floor.
  /// - `plane`: one 20 x 20 m wall whose front face is the plane y = 0 (normal -y), z in [-10, 10].
  static AnalyticScene make(const std::string& name);
  /// Names of the built-in scenes.
  static std::vector<std::string> names();

 private:
  /// The index colour() knows a primitive by, from what nearest_hit() found.
  int primitive_index(const SceneBox* box, const SceneSphere* sphere) const;

  std::string name_;
  std::vector<SceneBox> boxes_;
  std::vector<SceneSphere> spheres_;
};

}  // namespace aoscan
