/// @file recorder.h
/// @brief Writes any Source to a recording folder in TUM RGB-D layout (what `aoscan record` does).
#pragma once

#include <atomic>
#include <cstddef>
#include <optional>
#include <string>

#include "capture/source.h"

namespace aoscan {

/// What a recording run did.
struct RecordStats {
  std::size_t frames_written = 0;  ///< frames stored in the folder
  std::size_t frames_corrupt = 0;  ///< corrupt frames the source reported (skipped)
  /// A recording's frames whose timestamps repeat or go back (dropped, as a replay drops them).
  std::size_t frames_out_of_order = 0;
  std::size_t frames_dropped =
      0;  ///< live recording only: frames lost because the disk fell behind
  /// The source's error that ended the recording (bad input, device lost, internal), after every
  /// frame before it was written; ok when the source ended, was stopped or max_frames was reached.
  Status stopped_by = Status::ok();
};

/// Reads `source` until it ends, `max_frames` frames are written, or `*stop_requested` becomes
/// true (checked before every read; may be null), and writes into `dir` (created with its parents):
/// - depth/NNNNNN.png: 16-bit grey PNG per frame, NNNNNN = the frame's sequence (6+ digits);
/// - depth.txt: `#` header, then `timestamp depth/NNNNNN.png` per frame (timestamp %.6f s);
/// - camera.json: always (the source's calibration, or the first frame's if it differs);
/// - groundtruth.txt: TUM trajectory of the frames that carry T_world_camera_gt (if any do);
/// - scene.ply: source.scene_mesh() when the source has one.
/// Each frame's PNG is complete before its depth.txt and groundtruth.txt lines are flushed, so the
/// folder is a valid recording at any moment. Corrupt frames are skipped and counted; frames whose
/// calibration differs from camera.json's are counted as corrupt too; a recording's frames whose
/// timestamps repeat or go back are dropped and counted (TimestampOrder; the first is logged), so
/// the new recording's timestamps increase. A bad_input / device_lost /
/// internal status ends the recording: the files are closed and the status is returned in
/// `stopped_by` (throw_for_status() turns it into the matching Error), or thrown when no frame
/// could be written. Throws usage_error when `dir` already holds a depth.txt, Error (exit code 1)
/// when a file cannot be written.
RecordStats record_source(Source& source, const std::string& dir,
                          std::optional<std::size_t> max_frames,
                          const std::atomic<bool>* stop_requested);

}  // namespace aoscan
