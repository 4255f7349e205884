/// @file relocaliser.h
/// @brief Relocalisation after tracking loss: candidate poses from the keyframe database (and the
/// last good pose), each refined by ICP against the model raycast from it, and a geometric check
/// that a pose must pass before fusing starts again. A wrong pose would corrupt the model, so the
/// check would rather leave a frame lost than accept a doubtful one.
#pragma once

#include <memory>
#include <vector>

#include "core/intrinsics.h"
#include "core/pose.h"
#include "fusion/reconstruction_config.h"
#include "fusion/tracking/icp.h"
#include "fusion/tracking/keyframe_database.h"
#include "fusion/tsdf/tsdf_volume.h"

namespace aoscan {

/// How a frame's depth compares with the model raycast at a pose (pixels where the frame has
/// depth; see RelocalisationConfig for the tests).
struct DepthAgreement {
  int frame_pixels = 0;  ///< pixels with frame depth
  int both = 0;          ///< ... where the model has a surface too
  int agree = 0;         ///< ... within the tolerance
  int see_through = 0;   ///< ... where the frame sees beyond the model's surface
  double overlap() const { return frame_pixels > 0 ? double(both) / frame_pixels : 0.0; }
  double agreement() const { return both > 0 ? double(agree) / both : 0.0; }
  double see_through_ratio() const { return both > 0 ? double(see_through) / both : 1.0; }
};

/// Compares `frame_depth_m` with `model_depth_m` (same pixel grid, metres, 0 = none).
DepthAgreement compare_depth(const Image<float>& frame_depth_m, const Image<float>& model_depth_m,
                             double tolerance_m, double noise_reference_depth_m);

/// What one relocalisation attempt found.
struct RelocalisationResult {
  bool accepted = false;
  Pose T_world_camera;  ///< the verified pose (when accepted)
  IcpResult icp;        ///< the verifying ICP (when a candidate got that far)
  DepthAgreement agreement;    ///< the frame against the model at the pose (hinted rays)
  DepthAgreement see_through;  ///< ... against unhinted rays on a coarse grid
  int candidates_tried = 0;       ///< poses ICP started from
  std::vector<int> keyframes;     ///< the keyframes tried, most similar first
  IcpResult first_search;         ///< ICP from the first candidate (for diagnostics)
  int candidate_keyframe = -1;    ///< the accepted candidate's keyframe; -1: the last good pose
  /// Why the last candidate checked failed ("" when accepted): "too little depth", "no
  /// candidate", "ICP" (no candidate's ICP kept accept_inlier_ratio of the pixels), "ICP lost",
  /// "not converged", "inliers", "overlap", "agreement", "see-through".
  const char* rejection = "";
  double raycast_ms = 0.0, icp_ms = 0.0;  ///< time in raycasts and in ICP
};

/// The keyframe database of a take and the relocalisation of frames against its model.
class Relocaliser {
 public:
  explicit Relocaliser(const ReconstructionConfig& config);

  bool enabled() const { return config_.relocalisation.ferns > 0; }

  /// A well-tracked frame at `T_world_camera`: becomes a keyframe when it is unlike every other.
  /// The first keyframe sizes the raycast buffers of an attempt (the model's at `model_level` of
  /// the frame's pyramid), so that the first attempt after a loss is no slower than the others.
  void observe(const DepthPyramid& frame, const Pose& T_world_camera, int model_level);

  /// Looks for the pose of `frame` in the model `volume` (world frame): from the last good pose
  /// (its raycast `last_model`, may be null) and from the poses of the keyframes most like the
  /// frame, ICP against the model raycast at `model_intrinsics`; the candidate that matches best
  /// is checked (RelocalisationConfig). `workspace` is ICP's scratch: the tracker's, idle while
  /// the camera is lost and already sized. Never returns a non-finite pose.
  RelocalisationResult relocalise(const DepthPyramid& frame, const Intrinsics& model_intrinsics,
                                  int model_level, const TsdfVolume& volume,
                                  const std::shared_ptr<const RaycastResult>& last_model,
                                  IcpWorkspace& workspace);

  KeyframeDatabase& database() { return database_; }
  const KeyframeDatabase& database() const { return database_; }

 private:
  struct Candidate {
    Pose T_world_camera;
    int keyframe = -1;
  };
  /// The check of a pose (RelocalisationConfig); fills `result` and returns whether it passes.
  bool verify(const DepthPyramid& frame, const Intrinsics& model_intrinsics, int model_level,
              const TsdfVolume& volume, const Pose& T_world_camera, IcpWorkspace& workspace,
              RelocalisationResult& result);

  ReconstructionConfig config_;
  TrackingConfig search_;  ///< tracking with the relocalisation's wider motion limits
  KeyframeDatabase database_;
  /// Raycast buffers reused from attempt to attempt: a keyframe candidate's (at the frame's
  /// coarsest level), the check's hinted one and its coarse unhinted one, and the keyframe's
  /// depth hint in metres.
  RaycastResult search_model_, check_model_, see_through_model_;
  Image<float> hint_;
};

}  // namespace aoscan
