/// @file session_request_fuzz.cpp
/// @brief libFuzzer target: the body of the service's POST /api/sessions
/// (parse_session_request()): it either gives a request with a source, KEY=VALUE settings and
/// frames within 1 to 2^34, or refuses with a ServiceError 400 and a one-line message.
#include <string>

#include "fuzz/fuzz_input.h"
#include "serve/session_request.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace aoscan;
  const std::string body(reinterpret_cast<const char*>(data), size);
  try {
    const SessionRequest r = parse_session_request(body);
    if (r.source.empty()) fuzz::bug("a request without a source");
    for (const std::string& set : r.sets)
      if (set.find('=') == std::string::npos) fuzz::bug("a setting without '=': " + set);
    if (r.max_frames && (*r.max_frames == 0 || *r.max_frames > (std::size_t{1} << 34)))
      fuzz::bug("frames out of range");
  } catch (const ServiceError& e) {
    if (e.status() != 400) fuzz::bug("a status other than 400: " + std::to_string(e.status()));
    if (std::string(e.what()).empty()) fuzz::bug("an empty message");
  }
  return 0;
}
