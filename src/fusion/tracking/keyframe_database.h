/// @file keyframe_database.h
/// @brief Keyframes of a take encoded by randomised ferns over downsampled depth and normals
/// (Glocker, Shotton, Criminisi & Izadi 2015, with normals in place of colour), and the lookup of
/// the keyframes most like a frame: the candidates of relocalisation after tracking loss.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/pose.h"
#include "fusion/tracking/relocalisation_config.h"
#include "geometry/point_maps.h"

namespace aoscan {

/// A frame's fern codes: one code of fern_decisions bits per fern.
using FernCodes = std::vector<std::uint8_t>;

/// A keyframe: its codes, the pose it was tracked at (world frame of the model) and its depth at
/// the coarsest pyramid level (millimetres, 0 = none): fused at that pose, it is the depth hint
/// of the model raycast there, which makes that raycast a fraction of an unhinted one.
struct Keyframe {
  FernCodes codes;
  Pose T_world_camera;
  Image<std::uint16_t> depth_mm;
};

/// Millimetres of a depth in metres (0 for none or beyond 65.534 m).
Image<std::uint16_t> depth_to_mm(const Image<float>& depth_m);
/// Metres of a depth in millimetres.
void depth_from_mm(const Image<std::uint16_t>& depth_mm, Image<float>& depth_m);

/// One keyframe and how unlike a frame it is.
struct KeyframeMatch {
  int keyframe = -1;
  double dissimilarity = 1.0;  ///< fraction of ferns whose codes differ, in [0, 1]
};

/// The encoding image: a frame reduced to kFernImageWidth x kFernImageHeight pixels, each the
/// Gaussian-weighted mean of the valid depths (m) and unit normals (camera frame) around it.
inline constexpr int kFernImageWidth = 80;
inline constexpr int kFernImageHeight = 60;

/// The ferns (drawn once from a fixed seed: the same for every run with the same configuration,
/// so a saved database stays valid) and the keyframes encoded by them.
class KeyframeDatabase {
 public:
  explicit KeyframeDatabase(const RelocalisationConfig& config);

  /// The codes of a frame: each fern's decisions test one channel (depth, or one normal
  /// component) of one pixel of the frame's encoding image against a threshold; an invalid pixel
  /// answers no. Uses the coarsest level of `frame` (its maps carry their intrinsics).
  FernCodes encode(const DepthPyramid& frame) const;

  /// The `k` keyframes most like `codes`, most similar first (ties: the older keyframe first).
  std::vector<KeyframeMatch> nearest(const FernCodes& codes, int k) const;

  /// Adds `codes` as a keyframe at `T_world_camera` (with `frame`'s coarsest depth) when they
  /// differ from every keyframe's in more than keyframe_dissimilarity of the ferns and the
  /// database is not full; returns whether it did.
  bool add_if_novel(const FernCodes& codes, const Pose& T_world_camera,
                    const DepthPyramid& frame);

  /// Adds a keyframe unconditionally (loading a saved database); throws usage_error when its
  /// codes do not fit these ferns.
  void add(Keyframe keyframe);

  const std::vector<Keyframe>& keyframes() const { return keyframes_; }
  bool full() const;
  void clear();

 private:
  struct Decision {
    int x = 0, y = 0;      ///< pixel of the encoding image
    int channel = 0;       ///< 0 depth, 1..3 normal x, y, z
    float threshold = 0;  ///< the decision is value > threshold
  };
  /// Votes of `codes` for every keyframe: the number of ferns with the same code.
  void count_matches(const FernCodes& codes, std::vector<int>& votes) const;

  RelocalisationConfig config_;
  std::vector<Decision> decisions_;  ///< ferns x fern_decisions
  std::vector<Keyframe> keyframes_;
  /// For each fern and code value, the keyframes that have it (fern * 2^bits + code).
  std::vector<std::vector<int>> table_;
};

}  // namespace aoscan
