/// @file open_source.cpp
/// @brief SOURCE string → Source, as the contract spells sources.
#include "capture/source.h"

#include <filesystem>

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

/// What SOURCE may be, for messages.
constexpr const char* kSourceForms =
    "a TUM-layout folder with depth.txt, FILE.oni, synth:NAME, or a camera: openni2[:URI], "
    "freenect[:INDEX], v4l2:/dev/videoN, auto";

bool is_camera_spec(const std::string& spec) {
  return spec == "auto" || is_scheme(spec, "openni2") || is_scheme(spec, "freenect") ||
         starts_with(spec, "v4l2:");
}

std::unique_ptr<Source> open_source(const std::string& spec) {
  if (spec.empty()) throw usage_error("empty SOURCE");
  if (starts_with(spec, "synth:")) return open_synth_source(spec);
  if (spec == "auto") return open_first_camera();
  if (is_scheme(spec, "openni2")) return open_openni2_source(spec);
  if (is_scheme(spec, "freenect")) return open_freenect_source(spec);
  if (starts_with(spec, "v4l2:")) return open_v4l2_source(spec);
  if (ends_with(spec, ".oni")) return open_oni_file(spec);
  // Neither a scheme nor a folder: say what SOURCE may be rather than "no such folder".
  std::error_code ec;
  if (!std::filesystem::exists(spec, ec))
    throw input_error(spec + ": no such folder (SOURCE is " + kSourceForms + ")");
  return open_tum_folder(spec);
}

}  // namespace aoscan
