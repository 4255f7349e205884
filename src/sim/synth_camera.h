/// @file synth_camera.h
/// @brief The synthetic depth camera: analytic scenes ray-cast into depth frames along a smooth
/// handheld trajectory with exact poses, optionally with a Kinect v1 noise model (the `synth:`
/// source of capture/ reads its frames from here).
#pragma once

#include <cstdint>
#include <string>

#include "core/depth_frame.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/pose.h"
#include "sim/synth_scene.h"

namespace aoscan {

/// Sensor model applied when rendering.
enum class SynthNoise {
  kNone,    ///< exact depth of the ray through each pixel centre
  kKinect,  ///< Kinect v1: lateral jitter, axial noise, disparity quantisation, dropouts, range
};

/// Camera path of the synthetic source.
enum class SynthTrajectory {
  kOrbit,  ///< an arc around the scene's centre of interest (room: a slow turn looking across)
  kSweep,  ///< a lateral back-and-forth pass, panning with the motion
};

/// Parameters of the Kinect v1 model (noise=kinect). Depths z are along the optical axis (m).
inline constexpr double kKinectLateralSigmaPx = 0.5;     ///< ray jitter per image axis (pixels)
inline constexpr double kKinectBaselineM = 0.075;        ///< projector-camera baseline (m)
inline constexpr double kKinectDisparityStepPx = 0.125;  ///< disparity quantisation (pixels)
inline constexpr double kKinectMinDepthM = 0.4;          ///< nearer measurements are invalid
inline constexpr double kKinectMaxDepthM = 4.5;          ///< farther measurements are invalid
inline constexpr double kKinectDropoutStartDeg = 70.0;   ///< incidence where dropouts begin
inline constexpr double kKinectDropoutFullDeg = 80.0;    ///< incidence beyond which all drop out

/// Axial noise standard deviation of the Kinect v1 at depth z (metres): 0.0012 + 0.0019 (z-0.4)^2.
inline double kinect_axial_sigma_m(double z_m) {
  return 0.0012 + 0.0019 * (z_m - 0.4) * (z_m - 0.4);
}

/// Everything a `synth:` spec can set; defaults are the contract's.
struct SynthParams {
  std::string scene;  ///< one of AnalyticScene::names()
  int frames = 300;   ///< frames in the stream, 1..10^8
  int width = 640;    ///< image width (pixels), 1..4096
  int height = 480;   ///< image height (pixels), 1..4096
  SynthNoise noise = SynthNoise::kNone;
  std::uint64_t seed = 1;  ///< keys the noise and the trajectory's wobble
  SynthTrajectory trajectory = SynthTrajectory::kOrbit;
  double fps = 30.0;  ///< frame rate in (0, 1000]; frame i is at time i / fps (s)
  /// `colour=on`: frames come with a colour image from a colour camera registered to the depth
  /// camera, each surface the flat colour of its primitive (AnalyticScene::colour()), exact.
  bool colour = false;

  /// synth_intrinsics(width, height).
  Intrinsics intrinsics() const;
};

/// The simulated depth camera's intrinsics at width x height: fx = fy = 525 * width / 640,
/// cx = (width - 1) / 2, cy = (height - 1) / 2 (a Kinect's at 640 x 480).
Intrinsics synth_intrinsics(int width, int height);

/// Raw units per metre of synthetic frames.
inline constexpr double kSynthDepthScale = 5000.0;

/// Parses `synth:NAME[?key=value&...]` (keys: frames, width, height, noise, seed, trajectory, fps,
/// colour).
/// Throws usage_error, one line naming the spec and the offending scene or parameter and listing
/// the valid ones, on an unknown scene or key, a repeated key, or a bad value.
SynthParams parse_synth_spec(const std::string& spec);

/// Camera pose T_world_camera (camera: x right, y down, z forward; world: the scene's, metres) of
/// the built-in trajectory of `scene` at time `time_s` seconds. The path is a smooth function of
/// time whose main motion repeats every 24 s (speed below 0.4 m/s and turning below 20 deg/s,
/// i.e. < 1.5 cm and < 1.5 deg per frame at 30 Hz), at least 0.7 m from any surface; only its
/// small wobble (about 1 cm of tremor, a few cm of look-at drift, 1.5 deg of roll) depends on
/// `seed`. Trajectories are in time, so a lower `fps` gives larger steps between frames.
/// Throws usage_error for an unknown scene name.
Pose synth_camera_pose(const std::string& scene, SynthTrajectory trajectory, std::uint64_t seed,
                       double time_s);

/// T_world_camera of a camera at `eye` looking at `target` (camera x right, y down, z forward) with
/// the world direction `up` pointing up in the image, then rolled by `roll_rad` about the optical
/// axis. The built-in trajectories use up = +z (the scenes' world).
Pose look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up,
             double roll_rad = 0.0);

/// How to turn ray hits into raw depth.
struct SynthRenderOptions {
  SynthNoise noise = SynthNoise::kNone;
  std::uint64_t seed = 1;                 ///< noise key, with the frame index and pixel index
  std::uint64_t frame_index = 0;          ///< noise key
  double depth_scale = kSynthDepthScale;  ///< raw units per metre
};

/// Renders `scene` seen from T_world_camera into `depth` (resized to the intrinsics' size; raw
/// units, round to nearest). One ray per pixel through the pixel centre; depth is z in the camera
/// frame; 0 where nothing is hit or z is outside (0, 13 m] (noise=kinect: outside
/// [kKinectMinDepthM, kKinectMaxDepthM], or dropped out). Rows run in parallel through TBB; every
/// pixel is a pure function of its inputs, so the result is identical for any thread count.
void render_synth_depth(const AnalyticScene& scene, const Intrinsics& intrinsics,
                        const Pose& T_world_camera, const SynthRenderOptions& options,
                        Image<std::uint16_t>& depth);

/// Raw depth of pixel (u, v) of render_synth_depth() with the same arguments, its ray tested
/// against every primitive of the scene (no tile culling): the per-pixel arithmetic that the test
/// oracle render_synth_depth_reference() (tests/support) repeats pixel by pixel.
std::uint16_t render_synth_depth_pixel(const AnalyticScene& scene, const Intrinsics& intrinsics,
                                       const Pose& T_world_camera,
                                       const SynthRenderOptions& options, int u, int v);

/// The colour image of `scene` from T_world_camera: one exact ray per pixel centre (no noise),
/// the colour of the primitive hit (AnalyticScene::colour()), black where nothing is hit.
void render_synth_colour(const AnalyticScene& scene, const Intrinsics& intrinsics,
                         const Pose& T_world_camera, Image<Rgb8>& colour);

/// Frame `index` of the stream that `params` describes: its depth rendered from the trajectory's
/// pose at time index / fps with the params' noise and seed, `depth_scale` kSynthDepthScale,
/// `intrinsics` params.intrinsics(), `timestamp_s`, `sequence` = index and the exact pose as
/// `T_world_camera_gt`. `frame.origin` is the caller's to set. `scene` is
/// AnalyticScene::make(params.scene).
void render_synth_frame(const AnalyticScene& scene, const SynthParams& params, std::uint64_t index,
                        DepthFrame& frame);

}  // namespace aoscan
