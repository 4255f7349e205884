/// @file reconstruction.h
/// @brief The KinectFusion loop for one frame at a time: track against the model raycast,
/// integrate into the TSDF, raycast the model at the new pose. The one stateful owner of fusion.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

#include "core/mesh.h"
#include "core/pose.h"
#include "fusion/preprocess/preprocess.h"
#include "fusion/reconstruction_config.h"
#include "fusion/relocaliser.h"
#include "fusion/tracking/icp.h"
#include "fusion/tsdf/colour_volume.h"
#include "fusion/tsdf/raycast.h"
#include "fusion/tsdf/tsdf_integrator.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {

/// What happened to one frame.
struct FusionStep {
  TrackingStatus status = TrackingStatus::kLost;
  Pose T_world_camera;      ///< the tracked pose (the last good pose when lost)
  bool integrated = false;  ///< the frame was fused into the TSDF
  bool new_model = false;   ///< the first frame of a model (after start or reset): not tracked
  bool relocalised = false;  ///< tracking had been lost and this frame's pose passed the check
  /// While lost: the relocalisation attempt on this frame (candidates, the check's figures).
  RelocalisationResult relocalisation;
  IcpResult icp;            ///< tracking details (empty for the first frame of a model)
  IntegrateStats integrate;
  ColourIntegrateStats colour;  ///< the frame's colour fused (when it had colour and was fused)
};

/// A frame's colour image and the colour camera that took it (DepthFrame::colour and
/// DepthFrame::colour_camera of the source).
struct ColourInput {
  const Image<Rgb8>& image;
  const ColourCamera& camera;
};

/// Tracks and fuses a stream of preprocessed frames. World frame = camera frame of the first
/// frame of the model. Only this object writes the TSDF; raycasts it publishes are immutable.
class Reconstruction {
 public:
  explicit Reconstruction(const ReconstructionConfig& config);

  /// Tracks `frame` against the last model raycast (from the last good pose), integrates it unless
  /// tracking is lost, and raycasts the model at the new pose into `raycast_out`, which becomes the
  /// next tracking reference (keep it unchanged afterwards: it is shared from then on). When lost,
  /// `raycast_out` is left untouched and the reference stays the last good one, so tracking keeps
  /// trying from there and recovers when the camera comes back.
  /// Once a frame is lost the take stays lost (nothing fused) until a frame is relocalised: from
  /// the last good pose or from the keyframes most like it (Relocaliser), its pose must pass the
  /// relocalisation check. Every well-tracked frame may become a keyframe.
  /// While the model holds its first frame alone, the next frame is tracked against that frame's
  /// filtered maps at the raycast's resolution (its pyramid level) instead of the raycast.
  /// With `integrate` false (paused) the frame is tracked and raycast but not fused. The raycast
  /// has the resolution of pyramid level fusion.raycast_level of `intrinsics`, but at least 320
  /// pixels across (its maps carry their intrinsics), and uses the fused frame's depth at that
  /// level as its depth hint. A fused frame's `colour` (may be null or empty) is fused into the
  /// colour of the voxels it updated, unless fusion.colour is off.
  FusionStep process(const PreprocessedFrame& frame, const Intrinsics& intrinsics,
                     std::shared_ptr<RaycastResult> raycast_out, bool integrate = true,
                     const ColourInput* colour = nullptr);

  /// A kidnapped camera: `frame` relocalised against the model from the keyframes alone (not
  /// from the last good pose), with the check of process(); the reconstruction is left as it
  /// was. For measuring relocalisation.
  RelocalisationResult relocalise(const PreprocessedFrame& frame, const Intrinsics& intrinsics);

  /// Continues a saved take: the model restarts empty, `fill_volume` writes the saved TSDF (and
  /// its colour, if any) into the volume and its colour, `keyframes` become the keyframe database, and the take starts lost: nothing is
  /// fused until a frame is relocalised against those keyframes, in the saved world frame.
  /// Throws what fill_volume throws, and usage_error for keyframes that do not fit the ferns.
  void restore(const std::function<void(TsdfVolume&, ColourVolume&)>& fill_volume,
               std::vector<Keyframe> keyframes);

  /// Starts a new model: empty TSDF, identity pose for the next frame.
  void reset();

  const TsdfVolume& volume() const { return volume_; }
  /// The integrator that fuses the frames into volume() (its per-block bookkeeping).
  const TsdfIntegrator& integrator() const { return integrator_; }
  /// The colour of the volume's voxels (empty without colour).
  const ColourVolume& colour() const { return colour_; }
  /// The fused surface (world frame) by marching cubes with vertex normals; with vertex colours
  /// when any colour was fused (ColourVolume::sample(); a vertex without a coloured voxel around
  /// it is mid grey and counted in `colour_unobserved`, when given).
  TriangleMesh extract_mesh(std::size_t* colour_unobserved = nullptr) const;
  /// The fused colour of the surface seen at each pixel of `raycast` (a raycast of this volume,
  /// e.g. the one process() just made; camera-frame vertices at raycast.T_world_camera): the
  /// colour sampled at the pixel's world point as extract_mesh() samples a vertex, mid grey where
  /// no coloured voxel is near, black where the pixel has no surface. `out` gets the maps' size
  /// (its buffer reused), or is emptied when no colour has been fused (none in the run, or
  /// fusion.colour off). Reads the colour volume: call it on the thread that runs process().
  /// Multi-threaded over rows; the result does not depend on the thread count.
  void colour_image(const RaycastResult& raycast, Image<Rgb8>& out) const;
  /// The current tracking reference (null before the first frame and after reset()).
  std::shared_ptr<const RaycastResult> model() const { return model_; }
  /// Frames not fused because tracking was lost (or the model had no depth yet).
  std::size_t frames_lost() const { return frames_lost_; }
  /// Times tracking was lost (a good take followed by a lost frame).
  std::size_t losses() const { return losses_; }
  /// Times a lost take was relocalised.
  std::size_t relocalisations() const { return relocalisations_; }
  /// Tracking is lost: frames are not fused until one is relocalised.
  bool lost() const { return lost_; }
  const Relocaliser& relocaliser() const { return relocaliser_; }
  /// The resolution and pyramid level of the model raycast for frames of `intrinsics`.
  int model_level(const Intrinsics& intrinsics) const;

 private:
  ReconstructionConfig config_;
  TsdfVolume volume_;
  TsdfIntegrator integrator_;
  ColourVolume colour_;
  IcpWorkspace icp_workspace_;
  Relocaliser relocaliser_;
  std::shared_ptr<const RaycastResult> model_;
  /// The first frame's own filtered maps, tracked against instead of model_ while the model holds
  /// that frame alone (null otherwise).
  std::shared_ptr<const RaycastResult> first_frame_reference_;
  Pose T_world_last_;
  /// Smoothed frame-to-frame motion T_last^-1 T_new (camera frame; TrackingConfig::
  /// velocity_smoothing), valid while has_velocity_: the motion prior of the next frame.
  Pose velocity_;
  bool has_velocity_ = false;
  bool last_is_previous_ = false;  ///< T_world_last_ is the previous frame's pose (it was tracked)
  bool lost_ = false;
  std::size_t frames_lost_ = 0;
  std::size_t losses_ = 0;
  std::size_t relocalisations_ = 0;
};

}  // namespace aoscan
