/// @file kinect_disparity.cpp
/// @brief Kinect v1 disparity/depth conversion tables.
#include "capture/kinect_disparity.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace aoscan {
namespace {

constexpr double kFitA = -0.0030711016;
constexpr double kFitB = 3.3309495161;

struct Tables {
  std::array<std::uint16_t, kKinectRawCount> raw_to_mm{};
  int first_valid = 0;  ///< smallest raw with a depth
  int last_valid = -1;  ///< largest raw with a depth
};

const Tables& tables() {
  static const Tables t = [] {
    Tables built;
    for (int raw = 0; raw < kKinectRawCount; ++raw) {
      const double m = kinect_raw_to_m(static_cast<std::uint16_t>(raw));
      built.raw_to_mm[raw] = static_cast<std::uint16_t>(std::lround(m * 1000.0));
      if (built.raw_to_mm[raw] != 0) {
        if (built.last_valid < 0) built.first_valid = raw;
        built.last_valid = raw;
      }
    }
    return built;
  }();
  return t;
}

}  // namespace

double kinect_raw_to_m(std::uint16_t raw) {
  if (raw >= kKinectRawInvalid) return 0.0;
  const double denominator = kFitA * raw + kFitB;
  if (denominator <= 0.0) return 0.0;
  const double m = 1.0 / denominator;
  return m * 1000.0 <= kKinectMaxDepthMm ? m : 0.0;
}

const std::array<std::uint16_t, kKinectRawCount>& kinect_raw_to_mm_table() {
  return tables().raw_to_mm;
}

void kinect_raw_to_mm(const void* raw, std::size_t count, std::uint16_t* mm) {
  const std::uint16_t* table = tables().raw_to_mm.data();
  const auto* bytes = static_cast<const unsigned char*>(raw);
  for (std::size_t i = 0; i < count; ++i) {
    std::uint16_t r;
    std::memcpy(&r, bytes + 2 * i, sizeof r);  // unaligned-safe; compiles to a plain load
    mm[i] = r < kKinectRawCount ? table[r] : 0;
  }
}

std::uint16_t kinect_mm_to_raw(std::uint16_t mm) {
  const Tables& t = tables();
  if (mm == 0 || t.last_valid < t.first_valid) return kKinectRawInvalid;
  const auto begin = t.raw_to_mm.begin() + t.first_valid;
  const auto end = t.raw_to_mm.begin() + t.last_valid + 1;
  const auto upper = std::lower_bound(begin, end, mm);  // first table depth >= mm
  int best;
  if (upper == end) {
    best = t.last_valid;
  } else if (upper == begin) {
    best = t.first_valid;
  } else {
    const int hi = static_cast<int>(upper - t.raw_to_mm.begin());
    best = (mm - t.raw_to_mm[hi - 1] <= t.raw_to_mm[hi] - mm) ? hi - 1 : hi;
  }
  // Outside the table's span by more than half a step: not representable.
  const int step_lo = best > t.first_valid ? t.raw_to_mm[best] - t.raw_to_mm[best - 1]
                                           : t.raw_to_mm[best + 1] - t.raw_to_mm[best];
  const int step_hi = best < t.last_valid ? t.raw_to_mm[best + 1] - t.raw_to_mm[best]
                                          : t.raw_to_mm[best] - t.raw_to_mm[best - 1];
  const int diff = static_cast<int>(mm) - t.raw_to_mm[best];
  if (diff < 0 && -diff * 2 > step_lo) return kKinectRawInvalid;
  if (diff > 0 && diff * 2 > step_hi) return kKinectRawInvalid;
  return static_cast<std::uint16_t>(best);
}

}  // namespace aoscan
