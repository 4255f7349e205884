/// @file colour_stream.cpp
/// @brief Colour frame decoding and depth-colour pairing of the live cameras.
#include "capture/colour_stream.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <utility>

#include "io/colour_image.h"

namespace aoscan {
namespace {

std::uint8_t clamp_byte(int v) {
  return static_cast<std::uint8_t>(v < 0 ? 0 : v > 255 ? 255 : v);
}

/// BT.601 limited-range YCbCr to RGB in integers (the usual 8-bit fixed-point form).
Rgb8 yuv_to_rgb(int y, int u, int v) {
  const int c = 298 * (y - 16) + 128;
  const int d = u - 128;
  const int e = v - 128;
  return Rgb8{clamp_byte((c + 409 * e) >> 8), clamp_byte((c - 100 * d - 208 * e) >> 8),
              clamp_byte((c + 516 * d) >> 8)};
}

}  // namespace

Status decode_colour_frame(ColourPixelFormat format, const std::uint8_t* data,
                           std::size_t bytes_used, int width, int height, int bytes_per_line,
                           Image<Rgb8>& out, const std::string& origin) {
  if (format == ColourPixelFormat::kMjpeg) {
    // The stream's negotiated size, when known: a frame of another is refused undecoded.
    std::optional<ExpectedSize> expected;
    if (width > 0 && height > 0) expected = ExpectedSize{width, height};
    return decode_colour_image(data, bytes_used, out, origin, expected);
  }
  const int bytes_per_pixel = format == ColourPixelFormat::kRgb24 ? 3 : 2;
  if (width <= 0 || height <= 0 || bytes_per_line < bytes_per_pixel * width ||
      (format == ColourPixelFormat::kYuyv && width % 2 != 0))
    return Status::corrupt_frame(origin + ": impossible colour frame geometry " +
                                 size_text(width, height) + ", " + std::to_string(bytes_per_line) +
                                 " bytes per line");
  const std::size_t needed = static_cast<std::size_t>(bytes_per_line) * (height - 1) +
                             static_cast<std::size_t>(bytes_per_pixel) * width;
  if (!data || bytes_used < needed)
    return Status::corrupt_frame(origin + ": short colour frame (" + std::to_string(bytes_used) +
                                 " of " + std::to_string(needed) + " bytes)");
  if (out.width() != width || out.height() != height) out.resize(width, height);
  static_assert(sizeof(Rgb8) == 3, "Rgb8 rows are RGB24 rows");
  for (int y = 0; y < height; ++y) {
    const std::uint8_t* in = data + static_cast<std::size_t>(y) * bytes_per_line;
    Rgb8* row = out.row(y);
    if (format == ColourPixelFormat::kRgb24) {
      std::memcpy(row, in, static_cast<std::size_t>(width) * 3);
      continue;
    }
    for (int x = 0; x < width; x += 2, in += 4) {
      row[x] = yuv_to_rgb(in[0], in[1], in[3]);
      row[x + 1] = yuv_to_rgb(in[2], in[1], in[3]);
    }
  }
  return Status::ok();
}

ColourCamera registered_colour_camera(const Intrinsics& depth, int width, int height) {
  if (width == depth.width && height == depth.height) return ColourCamera::registered_to(depth);
  // The same view sampled on another pixel grid: pixel centres scale about the image corner.
  const double sx = static_cast<double>(width) / depth.width;
  const double sy = static_cast<double>(height) / depth.height;
  ColourCamera c;
  c.intrinsics.width = width;
  c.intrinsics.height = height;
  c.intrinsics.fx = depth.fx * sx;
  c.intrinsics.fy = depth.fy * sy;
  c.intrinsics.cx = (depth.cx + 0.5) * sx - 0.5;
  c.intrinsics.cy = (depth.cy + 0.5) * sy - 0.5;
  return c;
}

ColourPairer::ColourPairer(std::size_t capacity, double max_dt_s)
    : slots_(std::max<std::size_t>(capacity, 1)), max_dt_s_(max_dt_s) {}

Image<Rgb8>& ColourPairer::next_buffer() {
  return slots_[next_].image;
}

void ColourPairer::commit(double timestamp_s) {
  commit_failed(timestamp_s, std::string());
}

void ColourPairer::commit_failed(double timestamp_s, std::string why) {
  Slot& s = slots_[next_];
  s.timestamp_s = timestamp_s;
  s.error = std::move(why);
  s.filled = true;
  s.used = false;
  next_ = (next_ + 1) % slots_.size();
  ++received_;
  if (!have_newest_ || timestamp_s > newest_s_) newest_s_ = timestamp_s;
  have_newest_ = true;
}

bool ColourPairer::worth_waiting(double depth_timestamp_s, double stall_s) {
  if (!have_first_depth_) {
    first_depth_s_ = depth_timestamp_s;
    have_first_depth_ = true;
  }
  if (!have_newest_) return depth_timestamp_s - first_depth_s_ < stall_s;  // starting
  if (newest_s_ >= depth_timestamp_s) return false;  // a later frame is here: no better one
  return depth_timestamp_s - newest_s_ < stall_s;    // stopped: not waited for
}

void ColourPairer::pair(DepthFrame& frame, const ColourCamera& camera, const std::string& where) {
  frame.colour_camera = camera;
  frame.colour_error.clear();
  frame.colour_timestamp_s = 0.0;
  Slot* best = nullptr;
  double best_dt = 0.0;
  for (Slot& s : slots_) {
    if (!s.filled || s.used) continue;
    const double dt = std::abs(s.timestamp_s - frame.timestamp_s);
    // Ties: the earlier colour frame (as associate_lists()).
    if (dt <= max_dt_s_ &&
        (!best || dt < best_dt || (dt == best_dt && s.timestamp_s < best->timestamp_s))) {
      best = &s;
      best_dt = dt;
    }
  }
  if (!best) {
    frame.colour.resize(0, 0);
    frame.colour_error = where + ": no colour frame within " +
                         std::to_string(static_cast<int>(std::lround(max_dt_s_ * 1000.0))) +
                         " ms" + (received_ == 0 ? " (the colour stream delivered none)" : "");
    return;
  }
  best->used = true;
  if (!best->error.empty()) {
    frame.colour.resize(0, 0);
    frame.colour_error = best->error;
    return;
  }
  const Intrinsics& k = camera.intrinsics;
  if (best->image.width() != k.width || best->image.height() != k.height) {
    frame.colour.resize(0, 0);
    frame.colour_error = where + ": colour frame of " +
                         size_text(best->image.width(), best->image.height()) +
                         " differs from " + size_text(k.width, k.height) +
                         " of the colour camera";
    return;
  }
  std::swap(frame.colour, best->image);  // the frame's old buffer is recycled
  best->filled = false;
  frame.colour_timestamp_s = best->timestamp_s;
}

}  // namespace aoscan
