/// @file open_source.cpp
/// @brief SOURCE string → Source, as the contract spells sources.
#include "capture/source.h"

#include "capture/devices.h"
#include "capture/freenect_source.h"
#include "capture/openni2_source.h"
#include "capture/synth_source.h"
#include "capture/tum_source.h"
#include "capture/v4l2_source.h"

namespace aoscan {
namespace {

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}
bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}
/// `scheme`, `scheme:...` or `scheme?...` (a folder merely starting with the word is a folder).
bool is_scheme(const std::string& s, const std::string& scheme) {
  return s == scheme || starts_with(s, scheme + ":") || starts_with(s, scheme + "?");
}

}  // namespace

std::unique_ptr<Source> open_source(const std::string& spec) {
  if (spec.empty()) throw usage_error("empty SOURCE");
  if (starts_with(spec, "synth:")) return open_synth_source(spec);
  if (spec == "auto") return open_first_camera();
  if (is_scheme(spec, "openni2")) return open_openni2_source(spec);
  if (is_scheme(spec, "freenect")) return open_freenect_source(spec);
  if (starts_with(spec, "v4l2:")) return open_v4l2_source(spec);
  if (ends_with(spec, ".oni")) return open_oni_file(spec);
  return open_tum_folder(spec);
}

}  // namespace aoscan
