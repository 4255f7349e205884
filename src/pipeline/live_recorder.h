/// @file live_recorder.h
/// @brief `aoscan record` from a live camera: the camera is read on its own thread and handed to
/// the single-threaded recorder through a bounded queue, so a slow disk never stalls the camera.
#pragma once

#include <atomic>
#include <cstddef>
#include <optional>
#include <string>

#include "capture/recorder.h"
#include "capture/source.h"

namespace aoscan {

struct LiveRecordOptions {
  /// Frames that may wait for the disk (640x480 depth: 0.6 MB each). When the queue is full the
  /// oldest waiting frame is dropped and counted.
  std::size_t queue_capacity = 64;
};

/// Records `source` into `dir` exactly as record_source() does (same files, same errors), with the
/// reads on a camera thread and the writes on the calling thread. Stops when the source ends or
/// fails, after `max_frames` frames were read, or when `stop_requested` becomes true; frames
/// already read are always written (the queue is drained). Frames the disk could not keep up with
/// are dropped at the queue, never silently: RecordStats::frames_dropped counts them, and
/// frames_written + frames_dropped = frames read. Corrupt frames the camera reports are counted in
/// frames_corrupt. A device_lost / bad_input status ends the recording after the queue is drained
/// and is thrown as device_error / input_error, like record_source().
RecordStats record_live_source(Source& source, const std::string& dir,
                               std::optional<std::size_t> max_frames,
                               const std::atomic<bool>& stop_requested,
                               const LiveRecordOptions& options = {});

}  // namespace aoscan
