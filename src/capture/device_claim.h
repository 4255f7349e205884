/// @file device_claim.h
/// @brief In-process registry of open cameras: a second open of the same device is a clear
/// "busy" error instead of two streams fighting over one driver handle.
#pragma once

#include <mutex>
#include <set>
#include <string>

#include "core/status.h"

namespace aoscan {

/// Holds `key` (a canonical device id such as "freenect:0") while alive. Movable, not copyable.
class DeviceClaim {
 public:
  DeviceClaim() = default;
  /// Throws device_error "URI: busy: already open in this process" when `key` is held.
  DeviceClaim(const std::string& key, const std::string& uri) : key_(key) {
    std::lock_guard<std::mutex> lock(mutex());
    if (!held().insert(key_).second) {
      key_.clear();
      throw device_error(uri + ": busy: the device is already open in this process");
    }
  }
  DeviceClaim(DeviceClaim&& other) noexcept : key_(std::move(other.key_)) { other.key_.clear(); }
  DeviceClaim& operator=(DeviceClaim&& other) noexcept {
    if (this != &other) {
      release();
      key_ = std::move(other.key_);
      other.key_.clear();
    }
    return *this;
  }
  DeviceClaim(const DeviceClaim&) = delete;
  DeviceClaim& operator=(const DeviceClaim&) = delete;
  ~DeviceClaim() { release(); }

 private:
  void release() {
    if (key_.empty()) return;
    std::lock_guard<std::mutex> lock(mutex());
    held().erase(key_);
    key_.clear();
  }
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static std::set<std::string>& held() {
    static std::set<std::string> s;
    return s;
  }

  std::string key_;
};

}  // namespace aoscan
