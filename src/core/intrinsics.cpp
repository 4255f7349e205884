/// @file intrinsics.cpp
/// @brief Validation of pinhole intrinsics.
#include "core/intrinsics.h"

#include <cmath>

namespace aoscan {

bool Intrinsics::valid() const {
  return width > 0 && height > 0 && std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) &&
         std::isfinite(cy) && fx > 0 && fy > 0;
}

}  // namespace aoscan
