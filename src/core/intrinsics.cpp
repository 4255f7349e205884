/// @file intrinsics.cpp
/// @brief Validation of pinhole intrinsics.
#include "core/intrinsics.h"

#include <cmath>

namespace aoscan {

bool Intrinsics::valid() const {
  return width > 0 && height > 0 && std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) &&
         std::isfinite(cy) && fx > 0 && fy > 0;
}

std::string Intrinsics::implausible() const {
  // f >= size / (2 tan 85 deg): at most 170 degrees across.
  constexpr double kMinFocalPerPixel = 0.5 / 11.430052302761343;
  const auto text = [](double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  };
  if (!(cx >= 0 && cx <= width))
    return "cx " + text(cx) + " lies outside the image (0 to " + std::to_string(width) + ")";
  if (!(cy >= 0 && cy <= height))
    return "cy " + text(cy) + " lies outside the image (0 to " + std::to_string(height) + ")";
  if (!(fx >= kMinFocalPerPixel * width))
    return "fx " + text(fx) + " gives a field of view over 170 degrees across " +
           std::to_string(width) + " pixels";
  if (!(fy >= kMinFocalPerPixel * height))
    return "fy " + text(fy) + " gives a field of view over 170 degrees across " +
           std::to_string(height) + " pixels";
  return "";
}

}  // namespace aoscan
