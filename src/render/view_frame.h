/// @file view_frame.h
/// @brief What the live view and the snapshots show: one immutable product per fused frame
/// (raycast maps, SSAO, MVAO, fused colour, raw depth, HUD numbers, the fused surface), filled by
/// the pipeline.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/colour.h"
#include "core/image.h"
#include "core/intrinsics.h"
#include "core/mesh.h"
#include "core/pose.h"

namespace aoscan {

/// The views the live window cycles through with `v` (in this order) and the snapshots write.
enum class View {
  kShaded,      ///< model raycast: grey = MVAO x diffuse shading from the normals
  kSsao,        ///< the frame's SSAO as grey
  kMvao,        ///< the MVAO grid's AO of the surface seen at each pixel as grey
  kColour,      ///< the fused colour of the surface seen at each pixel
  kColourMvao,  ///< the fused colour x the MVAO
  kNormals,     ///< raycast normals as colours
  kDepth,       ///< raw depth through a colour map
  kOrbit,       ///< free orbit view of the fused surface (points shaded by their AO)
  kSplats,      ///< the orbit view's surface as blended Gaussian splats shaded by their AO
};
inline constexpr int kViewCount = 9;

/// True for the views of the fused surface seen from the orbit camera (kOrbit, kSplats): they
/// draw ViewFrame::surface, not the frame's images.
inline bool orbit_camera_view(View view) {
  return view == View::kOrbit || view == View::kSplats;
}

/// Short lower-case name used in snapshot file names and the HUD ("shaded", "ssao", "mvao",
/// "colour", "colour_mvao", ...).
const char* view_name(View view);
/// The view after `view` in the cycle (kSplats wraps to kShaded).
View next_view(View view);

/// Numbers the HUD shows; filled by the pipeline owner.
struct HudStats {
  double fps = 0.0;  ///< frames fused per second, recent average
  std::vector<std::pair<std::string, double>> stage_ms;  ///< per stage: name, recent ms per frame
  std::size_t frames_processed = 0;
  std::size_t frames_dropped = 0;
  bool integration_paused = false;
};

/// One fused frame as the renderer sees it. The images cover the frame of `intrinsics`, each at the
/// frame's resolution or at an integer fraction of it (the model raycast and what is computed on
/// it run at a pyramid level: a 320x240 raycast of a 640x480 frame); views enlarge them by pixel
/// replication. depth_m, normals, mvao and colour share one size. An image of another size, or
/// empty, shows as no data. Camera frame: x right, y down, z forward (metres).
/// The tracking state of a frame taken while tracking is lost: what the user should do.
inline constexpr const char* kTrackingLostState = "lost - move back to a scanned area";

struct ViewFrame {
  std::uint64_t sequence = 0;  ///< source frame index
  double timestamp_s = 0.0;    ///< source timestamp (s)
  Pose T_world_camera;         ///< pose of the raycast
  Intrinsics intrinsics;
  Image<float> depth_m;               ///< model raycast depth (m), 0 = no surface
  Image<Eigen::Vector3f> normals;     ///< raycast unit normals, camera frame; zero = invalid
  Image<float> ssao;                  ///< this frame's SSAO in [0, 1], 1 = open
  Image<float> mvao;                  ///< AO from the MVAO grid in [0, 1]; NaN = unobserved
  /// The fused colour (Reconstruction::colour_image()) of the surface at each raycast pixel; a
  /// surface without a coloured voxel near it is mid grey (as in mesh.ply). Empty when the run
  /// has no fused colour (a source without colour, fusion.colour=off, nothing coloured yet): the
  /// colour views then show the shaded view.
  Image<Rgb8> colour;
  Image<float> raw_depth_m;           ///< filtered input depth (m), 0 = invalid
  std::string tracking_state = "ok";  ///< e.g. "good", kTrackingLostState, "paused"
  HudStats hud;
  /// The fused surface in the world frame with per-vertex AO (quality) and normals, for the orbit
  /// views; null or empty until the pipeline exports one. Shared: publishing it is cheap.
  std::shared_ptr<const TriangleMesh> surface;
};

/// Frame pixels per pixel of `image` along each axis when it covers a `width` x `height` frame at
/// an integer fraction of that resolution (1: the same size, 2: half), or 0 when it does not
/// (empty, or any other size). Pixel (x, y) of the frame is image pixel (x / scale, y / scale).
template <class T>
int image_scale(const Image<T>& image, int width, int height) {
  if (image.width() <= 0 || image.height() <= 0 || width % image.width() != 0) return 0;
  const int scale = width / image.width();
  return image.height() * scale == height ? scale : 0;
}

}  // namespace aoscan
