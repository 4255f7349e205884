/// @file session_request.h
/// @brief What POST /api/sessions asks for, its parser, and the error the service answers a bad
/// request with. No dependencies beyond nlohmann-json (the parser is fuzzed on its own:
/// fuzz/session_request_fuzz.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace aoscan {

/// A request the service refuses; `status` is the HTTP status it answers with.
class ServiceError : public std::runtime_error {
 public:
  ServiceError(int status, const std::string& message)
      : std::runtime_error(message), status_(status) {}
  int status() const { return status_; }

 private:
  int status_;
};

/// What POST /api/sessions asks for.
struct SessionRequest {
  std::string source;  ///< as for replay/scan: a recording under data_dir, synth:, a camera
  std::vector<std::string> sets;          ///< KEY=VALUE, after the service's
  bool realtime = false;                  ///< pace a recording by its timestamps (as --realtime)
  std::optional<std::size_t> max_frames;  ///< as --frames
  std::optional<std::int64_t> loop;       ///< as replay --loop N (a recording or synth: scene)
};

/// The JSON body {"source": ..., "set": {KEY: VALUE, ...}, "realtime": bool, "frames": N,
/// "loop": N}: only "source" is required; values of "set" may be strings, numbers or booleans.
/// Throws ServiceError 400 with a one-line reason for anything else (not JSON, not an object, an
/// unknown key, a value of the wrong type, frames outside 1 to 2^34, no source).
SessionRequest parse_session_request(const std::string& body);

}  // namespace aoscan
