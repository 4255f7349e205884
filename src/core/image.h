/// @file image.h
/// @brief A dense row-major 2-D image of plain values (depth maps, vertex maps, AO maps).
#pragma once

#include <cassert>
#include <cstddef>
#include <string>
#include <vector>

namespace aoscan {

/// Row-major image; pixel (x, y) is column x of row y. Storage is reused by resize() so per-frame
/// code can keep one Image and refill it without allocating.
template <class T>
class Image {
 public:
  using value_type = T;

  Image() = default;
  Image(int width, int height, const T& fill = T{}) { resize(width, height, fill); }

  /// Sets the size; keeps the allocation when it is large enough. Pixels are set to `fill`.
  void resize(int width, int height, const T& fill = T{}) {
    assert(width >= 0 && height >= 0);
    width_ = width;
    height_ = height;
    data_.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), fill);
  }
  /// resize() for an output whose every pixel is written next: when the image has this size
  /// already its pixels are left as they are (no pass over them), else they are set to `fill`.
  void resize_for_overwrite(int width, int height, const T& fill = T{}) {
    if (width != width_ || height != height_) resize(width, height, fill);
  }
  void fill(const T& value) { data_.assign(data_.size(), value); }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t size() const { return data_.size(); }
  bool empty() const { return data_.empty(); }
  bool contains(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }

  T& operator()(int x, int y) {
    assert(contains(x, y));
    return data_[static_cast<std::size_t>(y) * width_ + x];
  }
  const T& operator()(int x, int y) const {
    assert(contains(x, y));
    return data_[static_cast<std::size_t>(y) * width_ + x];
  }
  T* row(int y) { return data_.data() + static_cast<std::size_t>(y) * width_; }
  const T* row(int y) const { return data_.data() + static_cast<std::size_t>(y) * width_; }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }

  bool operator==(const Image& other) const {
    return width_ == other.width_ && height_ == other.height_ && data_ == other.data_;
  }

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<T> data_;
};

/// An image size as messages say it: "640x480".
inline std::string size_text(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

}  // namespace aoscan
