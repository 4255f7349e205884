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
/// Pixels without data get `background`. Colours go to 8 bits as floor(255 * c + 0.5).
#pragma once

#include <string>

#include <Eigen/Core>

#include "core/image.h"
#include "core/mesh.h"
#include "render/view_frame.h"

namespace aoscan {

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
};

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

/// The view as an image: the size of frame.intrinsics for the image views; for kOrbit the same
/// size, seen from fit_orbit(*frame.surface). `out` is resized (its buffer reused). With `step`
/// > 1 the image is that many times smaller along each axis: its pixel (x, y) is the view's pixel
/// (x * step, y * step) (a step equal to model_scale() loses nothing of the model's views).
void composite_view(const ViewFrame& frame, View view, Image<Rgb8>& out,
                    const ViewStyle& style = {}, int step = 1);

/// Frame pixels per pixel of the frame's model raycast (2 for a half-resolution raycast), or 1
/// when the frame has none.
int model_scale(const ViewFrame& frame);

/// The orbit view of `mesh` from `camera` into `out` (its size is kept; must not be empty).
void composite_orbit(const TriangleMesh& mesh, const OrbitCamera& camera, Image<Rgb8>& out,
                     const ViewStyle& style = {});


}  // namespace aoscan
