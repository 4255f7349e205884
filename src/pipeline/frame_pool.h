/// @file frame_pool.h
/// @brief Recycles per-frame work items so the steady state of the chain allocates nothing.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

namespace aoscan {

/// Hands out `std::shared_ptr<T>` whose deleter returns the object to the pool instead of freeing
/// it, so its image buffers keep their capacity for the next frame. The pool must outlive every
/// pointer it handed out (the pipeline joins its threads before the pool goes away).
template <class T>
class ObjectPool {
 public:
  std::shared_ptr<T> acquire() {
    std::unique_ptr<T> object;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!free_.empty()) {
        object = std::move(free_.back());
        free_.pop_back();
      }
    }
    if (!object) {
      object = std::make_unique<T>();
      std::lock_guard<std::mutex> lock(mutex_);
      ++created_;
    }
    return std::shared_ptr<T>(object.release(), [this](T* released) {
      std::lock_guard<std::mutex> lock(mutex_);
      free_.emplace_back(released);
    });
  }

  /// Objects created so far (bounded by the number in flight at once).
  std::size_t created() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return created_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::unique_ptr<T>> free_;
  std::size_t created_ = 0;
};

}  // namespace aoscan
