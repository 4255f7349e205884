/// @file view_commands.cpp
/// @brief The live view's command queue.
#include "render/view_commands.h"

namespace aoscan {

const char* command_name(ViewCommand command) {
  switch (command) {
    case ViewCommand::kResetModel:
      return "reset";
    case ViewCommand::kPauseIntegration:
      return "pause";
    case ViewCommand::kResumeIntegration:
      return "resume";
    case ViewCommand::kWriteOutputs:
      return "write";
    case ViewCommand::kQuit:
      return "quit";
  }
  return "unknown";
}

bool ViewCommandQueue::push(ViewCommand command) {
  if (command == ViewCommand::kQuit) quit_.store(true);
  if (command == ViewCommand::kPauseIntegration) paused_.store(true);
  if (command == ViewCommand::kResumeIntegration) paused_.store(false);
  std::lock_guard<std::mutex> lock(mutex_);
  if (queue_.size() >= kCapacity) {
    ++dropped_;
    return false;
  }
  queue_.push_back(command);
  return true;
}

std::optional<ViewCommand> ViewCommandQueue::poll() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (queue_.empty()) return std::nullopt;
  const ViewCommand command = queue_.front();
  queue_.pop_front();
  return command;
}

std::vector<ViewCommand> ViewCommandQueue::drain() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<ViewCommand> out(queue_.begin(), queue_.end());
  queue_.clear();
  return out;
}

std::size_t ViewCommandQueue::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

}  // namespace aoscan
