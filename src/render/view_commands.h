/// @file view_commands.h
/// @brief The user's requests from the live view (keys, closing the window), queued for the
/// pipeline owner to poll. Thread-safe; the renderer never calls into the pipeline.
#pragma once

#include <atomic>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <vector>

namespace aoscan {

/// What a key asks the pipeline to do.
enum class ViewCommand {
  kResetModel,         ///< `r`: clear the TSDF and the MVAO grid, start over from the next frame
  kPauseIntegration,   ///< `space` (when running): keep tracking and showing, stop integrating
  kResumeIntegration,  ///< `space` (when paused)
  kWriteOutputs,       ///< `s`: write mesh.ply, mesh.glb, trajectory.txt now
  kQuit,               ///< `q`, `Esc` or the window closed: stop the run, writing the outputs
};

const char* command_name(ViewCommand command);

/// A bounded FIFO of commands plus sticky flags. When full (kCapacity commands nobody polled) a new
/// command is dropped and counted, except kQuit, which is also kept in quit_requested().
class ViewCommandQueue {
 public:
  static constexpr std::size_t kCapacity = 64;

  /// Queues `command` (any thread). Returns false when it was dropped because the queue is full.
  bool push(ViewCommand command);
  /// The oldest queued command, or nullopt (any thread, never blocks).
  std::optional<ViewCommand> poll();
  /// Every queued command, oldest first.
  std::vector<ViewCommand> drain();

  /// True once kQuit was pushed (stays true).
  bool quit_requested() const { return quit_.load(); }
  /// Integration state implied by the last pause/resume pushed.
  bool integration_paused() const { return paused_.load(); }
  std::size_t dropped() const;

 private:
  mutable std::mutex mutex_;
  std::deque<ViewCommand> queue_;
  std::size_t dropped_ = 0;
  std::atomic<bool> quit_{false};
  std::atomic<bool> paused_{false};
};

}  // namespace aoscan
