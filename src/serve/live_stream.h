/// @file live_stream.h
/// @brief The service's live view: the running session's view frames, composited on the CPU at
/// the model raycast's resolution and encoded as JPEG at most `max_fps` times a second, by a
/// thread of low priority (kViewerNice), handed to each viewer latest-wins, plus the
/// HUD figures of the newest frame for the status. A slow viewer skips frames; it never slows
/// fusion or the other viewers.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/view_frame.h"

namespace aoscan {

class ViewStage;

/// Nice levels below the pipeline at which the stream's thread and the viewers' senders run.
inline constexpr int kViewerNice = 10;

/// The HUD figures of the newest frame the stream took.
struct LiveFigures {
  bool valid = false;  ///< false until a frame was taken
  std::uint64_t sequence = 0;
  double fps = 0.0;
  std::vector<std::pair<std::string, double>> stage_ms;
  std::size_t frames_processed = 0;
  std::size_t frames_dropped = 0;
  bool integration_paused = false;
  std::string tracking_state;

  nlohmann::json to_json() const;
};

/// One encoded frame of a view.
struct EncodedFrame {
  View view = View::kShaded;
  std::uint64_t sequence = 0;
  std::vector<std::uint8_t> jpeg;
};

/// One viewer's slot: the newest frame of its view not yet taken (latest wins).
class LiveViewer {
 public:
  explicit LiveViewer(View view) : view_(view) {}
  View view() const;
  void set_view(View view);
  /// The newest frame not yet returned, waiting up to `timeout`; null on timeout or once closed.
  std::shared_ptr<const EncodedFrame> next(std::chrono::milliseconds timeout);
  /// Wakes next() for good.
  void close();
  bool closed() const;
  std::size_t frames_skipped() const;  ///< replaced before the viewer took them

 private:
  friend class LiveStream;
  void offer(std::shared_ptr<const EncodedFrame> frame);

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  View view_;
  std::shared_ptr<const EncodedFrame> pending_;
  bool closed_ = false;
  std::size_t skipped_ = 0;
};

struct LiveStreamOptions {
  double max_fps = 15.0;       ///< frames encoded per second at most (for all viewers together)
  double status_hz = 2.0;      ///< frames taken per second for the figures when nobody watches
  int jpeg_quality = 75;
  std::size_t max_viewers = 32;
};

/// Owns the thread that takes the frames. attach() and the viewer calls are thread-safe.
class LiveStream {
 public:
  explicit LiveStream(LiveStreamOptions options = {});
  ~LiveStream();
  LiveStream(const LiveStream&) = delete;
  LiveStream& operator=(const LiveStream&) = delete;

  /// The session's view stage (RunOptions::remote_view), or null when its chain has stopped:
  /// returns once the stream holds none of its frames. The figures are cleared on attach.
  void attach(ViewStage* stage);
  /// A new viewer of `view`; null when max_viewers are connected.
  std::shared_ptr<LiveViewer> add_viewer(View view);
  void remove_viewer(const std::shared_ptr<LiveViewer>& viewer);
  /// Sends the current frame again at the next tick (a viewer changed its view).
  void refresh();
  std::size_t viewers() const;
  LiveFigures figures() const;
  std::size_t frames_encoded() const;

  /// One step of the thread's work: takes the newest frame of the attached stage (when it is new)
  /// and hands it to the viewers. Public for tests, which drive it without the thread.
  void pump();

 private:
  void loop();

  LiveStreamOptions options_;
  mutable std::mutex stage_mutex_;  ///< held while a frame of the stage is in use
  ViewStage* stage_ = nullptr;
  std::uint64_t last_sequence_ = 0;
  bool have_last_ = false;
  std::atomic<bool> resend_{false};

  mutable std::mutex mutex_;  ///< viewers_, figures_, counters
  std::vector<std::shared_ptr<LiveViewer>> viewers_;
  LiveFigures figures_;
  std::size_t frames_encoded_ = 0;

  std::mutex wake_mutex_;
  std::condition_variable wake_;
  bool done_ = false;
  std::thread thread_;
};

/// The view named `name` ("shaded", "ssao", "mvao", ...), or nullopt.
std::optional<View> view_named(const std::string& name);

}  // namespace aoscan
