/// @file open_source.cpp
/// @brief SOURCE string → Source, as the contract spells sources.
#include "capture/source.h"

#include "capture/synth_source.h"
#include "capture/tum_source.h"

namespace aoscan {
namespace {

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}
bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

std::unique_ptr<Source> open_source(const std::string& spec) {
  if (spec.empty()) throw usage_error("empty SOURCE");
  if (starts_with(spec, "synth:")) return open_synth_source(spec);
  if (ends_with(spec, ".oni"))
    throw usage_error(spec + ": OpenNI2 .oni playback is not supported by this build");
  if (spec == "auto" || starts_with(spec, "openni2") || starts_with(spec, "freenect") ||
      starts_with(spec, "v4l2:"))
    throw device_error(spec + ": live cameras are not supported by this build (tried: none of "
                              "OpenNI2, libfreenect, V4L2 is compiled in)");
  return open_tum_folder(spec);
}

}  // namespace aoscan
