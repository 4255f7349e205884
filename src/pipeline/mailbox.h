/// @file mailbox.h
/// @brief A latest-value mailbox: the producer overwrites, a reader (the render thread) takes the
/// newest value and never makes the producer wait for it.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <utility>

namespace aoscan {

/// Holds the latest value put; older values are replaced, never queued. `T` is typically a
/// `std::shared_ptr<const Product>` so that taking it is cheap and the product is immutable.
template <class T>
class Mailbox {
 public:
  /// Replaces the held value and bumps the version.
  void put(T value) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      value_ = std::move(value);
      ++version_;
    }
    changed_.notify_all();
  }

  /// The latest value (a copy) and its version; nullopt before the first put().
  std::optional<std::pair<T, std::uint64_t>> latest() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!value_) return std::nullopt;
    return std::make_pair(*value_, version_);
  }

  /// Waits until a value newer than `seen_version` exists or the mailbox is closed or the timeout
  /// passes; returns the latest value if it is newer.
  template <class Rep, class Period>
  std::optional<std::pair<T, std::uint64_t>> wait_newer(std::uint64_t seen_version,
                                                        std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, timeout, [&] { return closed_ || version_ > seen_version; });
    if (!value_ || version_ <= seen_version) return std::nullopt;
    return std::make_pair(*value_, version_);
  }

  /// Wakes waiters for good (the producer has finished).
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    changed_.notify_all();
  }

  std::uint64_t version() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return version_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<T> value_;
  std::uint64_t version_ = 0;
  bool closed_ = false;
};

}  // namespace aoscan
