/// @file composite.h
/// @brief CPU compositing of every view: the reference for the GL shaders (same formulas, same
/// constants) and the headless snapshot path.
///
/// Shading, per pixel of a ViewFrame (camera frame: x right, y down, z forward):
///  - kShaded:  grey = ao * (ambient + (1 - ambient) * max(0, n . l)), ao = clamp(mvao, 0, 1)
///              (unobserved, i.e. NaN or negative, counts as 1); no surface where depth_m <= 0 or
///              the normal is zero.
///  - kSsao:    grey = clamp(ssao, 0, 1); no data where the SSAO is NaN or negative.
///  - kMvao:    grey = clamp(mvao, 0, 1), no diffuse term; no surface as kShaded; no data where
///              the MVAO is NaN or negative, i.e. its grid cell was never observed (like kSsao's
///              no data; kShaded shades it as open).
///  - kColour:  rgb = the fused colour (ViewFrame::colour); no surface as kShaded.
///  - kColourMvao: rgb = colour * ao per channel, ao as in kShaded (unobserved counts as 1), no
///              diffuse term (the fused colour already carries the scene's real shading).
///              Both colour views show kShaded's grey when the frame has no colour image (a run
///              without colour).
///  - kNormals: rgb = 0.5 + 0.5 * (n.x, -n.y, -n.z) (a camera-facing normal is (128, 128, 255)).
///  - kDepth:   raw depth (the raycast depth when no raw depth is published) through a 5-stop
///              blue-cyan-green-yellow-red map over [depth_min_m, depth_max_m].
///  - kOrbit:   the surface's vertices as square points of point_size_px, grey = AO x diffuse with
///              the same light fixed to the orbit camera, z-buffered.
///  - kSplats:  the same vertices, camera, shade and culling (by the centre, as GL points) as
///              kOrbit, drawn as Gaussian splats blended in three passes (Scanopy): each vertex is
///              a screen-aligned disk of world radius R = splat_radius_per_spacing x the surface's
///              point spacing (surface_spacing_m), i.e. of r = R x f / z pixels at eye depth z
///              (f: pixels per metre at 1 m), r clamped to [kSplatMinRadiusPx, kSplatMaxRadiusPx];
///              a pixel whose centre is at distance d < r from the projected centre is covered
///              with weight w = exp(-d^2 / (2 sigma^2)), sigma = r / 2. Pass 1 keeps per pixel the
///              nearest window depth of the covering splats pushed back by epsilon = R along the
///              eye's z; pass 2 sums w x shade and w over the covering splats whose own window
///              depth is <= that depth (the front surface's splats within epsilon, in vertex
///              order); pass 3 writes grey = sum(w x shade) / sum(w), the background where no
///              splat covers the pixel.
/// Pixels without data get `background`. Colours go to 8 bits as floor(255 * c + 0.5).
#pragma once

#include <string>

#include <Eigen/Core>

#include "core/image.h"
#include "core/mesh.h"
#include "render/view_frame.h"

namespace aoscan {

/// Point spacing of the live orbit view's surface cloud (m): one point per voxel of this side
/// (SurfaceCloudOptions::voxel_m of the view stage, and the splats' spacing for a cloud without
/// faces, ViewStyle::splat_spacing_m).
inline constexpr double kSurfaceCloudSpacingM = 0.01;

/// Shading constants shared by the CPU composite and the shaders (passed as uniforms).
struct ViewStyle {
  float ambient = 0.25f;  ///< diffuse floor of the shaded views, in [0, 1]
  /// Unit direction towards the light in the viewing camera's frame (x right, y down, z forward):
  /// a headlight slightly above and left of the camera.
  Eigen::Vector3f to_light_camera = Eigen::Vector3f(-0.25f, -0.35f, -1.0f).normalized();
  float depth_min_m = 0.4f;  ///< depth colour map: first stop (m)
  float depth_max_m = 4.5f;  ///< depth colour map: last stop (m)
  Rgb8 background{24, 24, 32};
  float point_size_px = 2.0f;  ///< orbit view: side of each vertex's square (pixels)
  /// Splats view: the point spacing of a surface without faces (m), the view stage's orbit cloud;
  /// a mesh with faces uses its mean edge length instead (surface_spacing_m).
  float splat_spacing_m = static_cast<float>(kSurfaceCloudSpacingM);
  /// Splats view: disk radius / point spacing. 1.5: the cloud's points lie anywhere in their
  /// voxels, neighbours up to about two spacings apart; the disks overlap without holes.
  float splat_radius_per_spacing = 1.5f;
};

/// The splats view's disk radius on screen is kept within these (pixels): at least a pixel
/// centre lies within kSplatMinRadiusPx of any point (sqrt(2) / 2 < 0.75), so a distant splat
/// still covers a pixel; the largest keeps the GL point holding a disk (2 r + 1 pixels) well
/// below the point sizes GL implementations draw (255 in Mesa).
inline constexpr float kSplatMinRadiusPx = 0.75f;
inline constexpr float kSplatMaxRadiusPx = 64.0f;

/// A camera orbiting `target_world` (world frame of the pipeline = first camera's frame, y down).
/// yaw = pitch = 0 looks along +z like the first camera; yaw turns about the world's up (-y) axis,
/// positive pitch looks down on the target.
struct OrbitCamera {
  Eigen::Vector3f target_world = Eigen::Vector3f::Zero();
  float yaw_rad = 0.0f;
  float pitch_rad = 0.0f;
  float distance_m = 2.0f;  ///< eye to target (m)
  float fov_y_rad = 1.0f;   ///< vertical field of view
};
/// Pitch is kept within +-kOrbitMaxPitchRad so that the camera never looks straight up or down.
inline constexpr float kOrbitMaxPitchRad = 1.5f;

/// A camera that frames `mesh` (bounding-box centre, whole box in view) from yaw = pitch = 0, or
/// the default camera for an empty mesh.
OrbitCamera fit_orbit(const TriangleMesh& mesh);

/// Column-major 4x4 clip-from-world matrix of `camera` for an image of `aspect` = width / height
/// (OpenGL conventions: eye looks down -z, y up, depth in [-1, 1]; near and far planes at 0.01 and
/// 100 times the distance); `view` receives eye-from-world, `projection` clip-from-eye.
Eigen::Matrix4f orbit_clip_from_world(const OrbitCamera& camera, float aspect,
                                      Eigen::Matrix4f* view = nullptr,
                                      Eigen::Matrix4f* projection = nullptr);

/// Orbit-view inputs of mesh vertex `i`: its AO (quality clamped to [0, 1]; 1 when the mesh has no
/// quality or it is NaN) and its normal (zero when absent or not finite: no diffuse term).
float vertex_ao(const TriangleMesh& mesh, std::size_t i);
Eigen::Vector3f vertex_normal(const TriangleMesh& mesh, std::size_t i);

/// The mean length of `mesh`'s face edges (each face's three edges; faces with an index out of
/// range or a non-finite vertex are skipped), or 0 when it has none (m).
float mean_edge_length_m(const TriangleMesh& mesh);
/// The splats view's point spacing of `mesh` (m): mean_edge_length_m(), or style.splat_spacing_m
/// for a surface without faces (the orbit cloud).
float surface_spacing_m(const TriangleMesh& mesh, const ViewStyle& style);

/// 8-bit colour of a value in [0, 1] (clamped) as floor(255 * c + 0.5).
std::uint8_t to_u8(float c);

/// Per-pixel shading of the image views (the functions the fragment shaders mirror).
Rgb8 shade_mvao(float depth_m, const Eigen::Vector3f& normal_camera, float mvao,
                const ViewStyle& style);
Rgb8 shade_ssao(float ssao, const ViewStyle& style);
/// kMvao: the grey of the AO at a pixel with a surface (kSsao's formula on the MVAO image).
Rgb8 shade_mvao_grey(float depth_m, const Eigen::Vector3f& normal_camera, float mvao,
                     const ViewStyle& style);
Rgb8 shade_colour(float depth_m, const Eigen::Vector3f& normal_camera, Rgb8 colour,
                  const ViewStyle& style);
Rgb8 shade_colour_mvao(float depth_m, const Eigen::Vector3f& normal_camera, Rgb8 colour,
                       float mvao, const ViewStyle& style);
Rgb8 shade_normal(float depth_m, const Eigen::Vector3f& normal_camera, const ViewStyle& style);
Rgb8 shade_depth(float depth_m, const ViewStyle& style);

/// The view as an image: the size of frame.intrinsics for the image views; for kOrbit and kSplats
/// the same size, seen from fit_orbit(*frame.surface). `out` is resized (its buffer reused). With
/// `step` > 1 the image is that many times smaller along each axis: its pixel (x, y) is the view's
/// pixel (x * step, y * step) (a step equal to model_scale() loses nothing of the model's views).
void composite_view(const ViewFrame& frame, View view, Image<Rgb8>& out,
                    const ViewStyle& style = {}, int step = 1);

/// Frame pixels per pixel of the frame's model raycast (2 for a half-resolution raycast), or 1
/// when the frame has none.
int model_scale(const ViewFrame& frame);

/// The orbit view of `mesh` from `camera` into `out` (its size is kept; must not be empty).
void composite_orbit(const TriangleMesh& mesh, const OrbitCamera& camera, Image<Rgb8>& out,
                     const ViewStyle& style = {});
/// The splats view of `mesh` from `camera` into `out` (its size is kept; must not be empty).
void composite_splats(const TriangleMesh& mesh, const OrbitCamera& camera, Image<Rgb8>& out,
                      const ViewStyle& style = {});

}  // namespace aoscan
