/// @file kinect_disparity.h
/// @brief Kinect v1 raw 11-bit disparity to depth and back (pure functions, no libfreenect).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace aoscan {

/// Raw value the Kinect v1 sends for "no measurement".
constexpr std::uint16_t kKinectRawInvalid = 2047;
/// Number of distinct 11-bit raw values.
constexpr int kKinectRawCount = 2048;
/// Depths beyond this are reported invalid (the sensor's useful range ends well before), mm.
constexpr std::uint16_t kKinectMaxDepthMm = 10000;

/// Depth in metres along the optical axis for raw disparity `raw`, by the widely used
/// inverse-linear fit z = 1 / (-0.0030711016 * raw + 3.3309495161) (N. Burrus' calibration).
/// Returns 0 for kKinectRawInvalid, raw values past the fit's pole and depths above
/// kKinectMaxDepthMm. Reference implementation of the table below.
double kinect_raw_to_m(std::uint16_t raw);

/// kinect_raw_to_m(raw) in whole millimetres (rounded), 0 = invalid, for every raw value.
/// Built once; depth never decreases with raw over the valid range.
const std::array<std::uint16_t, kKinectRawCount>& kinect_raw_to_mm_table();

/// Converts `count` raw pixels to millimetres through the table (fast path of the capture edge);
/// raw values above 2047 count as invalid. `raw` need not be 2-byte aligned (libfreenect's frame
/// buffers are not always).
void kinect_raw_to_mm(const void* raw, std::size_t count, std::uint16_t* mm);

/// The raw disparity whose table depth is nearest to `mm` (ties take the smaller raw), or
/// kKinectRawInvalid for 0 and for depths outside the table's range (beyond half a step).
std::uint16_t kinect_mm_to_raw(std::uint16_t mm);

}  // namespace aoscan
