/// @file snapshot.h
/// @brief `--snapshot DIR [--snapshot-every N]`: PNGs of the views composited on the CPU (no GL,
/// no display), so they work headless too.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/status.h"
#include "render/composite.h"
#include "render/view_frame.h"

namespace aoscan {

struct SnapshotOptions {
  std::string dir;            ///< created if missing
  std::uint64_t every_n = 1;  ///< write every N-th offered frame (the first one included)
  /// Every view, in the `v` cycle's order.
  std::vector<View> views = {View::kShaded, View::kSsao,       View::kMvao,
                             View::kColour, View::kColourMvao, View::kNormals,
                             View::kDepth,  View::kOrbit,      View::kSplats};
  ViewStyle style;
  /// Also write the model raycast's depth (io/snapshot_files.h), for tools that place the views'
  /// pixels in the world.
  bool raycast_depth = true;
};

/// Writes `DIR/<view>_<sequence, 6 digits>.png` for each view, and the model raycast's depth as
/// `DIR/raycast_depth_<sequence>.png` (io/snapshot_files.h). Costs one composite plus one PNG
/// encode per view, too slow for the fusion path: call it off that path (the render thread or the
/// output stage). Not thread-safe: one caller.
class SnapshotWriter {
 public:
  /// Creates the folder; throws usage_error naming it when it cannot be created, usage_error when
  /// every_n is 0.
  explicit SnapshotWriter(SnapshotOptions options);

  /// Counts the frame and writes its views when it is due (frames 0, N, 2N, ... of the offers).
  /// Returns ok (also when not due) or an internal status naming the file that failed.
  Status offer(const ViewFrame& frame);
  /// Writes the views of `frame` now (e.g. for the `s` key or the last frame).
  Status write(const ViewFrame& frame);

  /// Path of the snapshot of `view` for a frame with `sequence`.
  std::string path(View view, std::uint64_t sequence) const;
  /// Path of the file named `name` (a view's, or kRaycastDepthView) for a frame with `sequence`.
  std::string path(const char* name, std::uint64_t sequence) const;
  std::size_t files_written() const { return files_written_; }

 private:
  SnapshotOptions options_;
  Image<Rgb8> buffer_;
  Image<std::uint16_t> depth_units_;
  std::uint64_t offered_ = 0;
  std::size_t files_written_ = 0;
};

}  // namespace aoscan
