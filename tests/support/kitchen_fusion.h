/// @file kitchen_fusion.h
/// @brief The KinectFusion loop (icp -> integrate -> raycast, then marching cubes) on the 7-Scenes
/// RedKitchen recording with a small stand-in preprocessing (bilateral filter, 2x2 pyramid,
/// central-difference normals), timing each kernel. Shared by tests/fusion/kitchen_test.cpp
/// (tracking against the reference poses) and the aoscan-kitchen-bench benchmark; free of
/// GoogleTest.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "core/intrinsics.h"
#include "core/pose.h"

namespace aoscan::test {

/// The recording's depth camera.
inline const Intrinsics kKitchenIntrinsics{640, 480, 585.0, 585.0, 320.0, 240.0};

/// A depth frame of the recording and its reference pose.
struct KitchenFrame {
  std::string path;
  Pose T_world_camera_gt;
};

/// True when `dir` holds a readable depth.txt.
bool kitchen_present(const std::string& dir);

/// `dir`/depth.txt paired line by line with `dir`/groundtruth.txt (same timestamps in this
/// recording), at most `max_frames` of them.
std::vector<KitchenFrame> read_kitchen(const std::string& dir, int max_frames);

struct KitchenRunOptions {
  int max_frames = 20;
  bool mesh = false;     ///< extract the mesh at the end (timed)
  int kernel_loops = 0;  ///< > 0: repeat each kernel on the last frame and print its times
  bool verbose = false;  ///< print every frame's ICP outcome and the eigenvalues of its system
  bool fuse_at_reference = false;  ///< fuse at the reference poses (ICP still runs, from the
                                   ///< previous reference pose)
  bool no_hint = false;            ///< raycast without the depth hint
};

struct KitchenRunStats {
  double ate_m = 0;
  int good = 0, poor = 0, lost = 0;
  std::vector<double> ms_preprocess, ms_icp, ms_integrate, ms_raycast;
  double ms_mesh = 0;
  std::size_t mesh_vertices = 0, mesh_faces = 0;
  int blocks = 0;
  double volume_mb = 0;
  std::vector<std::string> read_errors;  ///< one line per depth PNG that could not be read
};

/// The KinectFusion loop over the first frames of the recording in `dir`; world = first
/// reference pose. ATE is against the reference poses.
KitchenRunStats run_kitchen(const std::string& dir, const KitchenRunOptions& options);

}  // namespace aoscan::test
