/// @file session_request.cpp
/// @brief The body of POST /api/sessions (session_request.h).
#include "serve/session_request.h"

#include <cstdint>

#include <nlohmann/json.hpp>

namespace aoscan {

SessionRequest parse_session_request(const std::string& body) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(body);
  } catch (const nlohmann::json::exception&) {
    throw ServiceError(400, "the body is not JSON (expected {\"source\": ..., \"set\": {...}})");
  }
  if (!json.is_object()) throw ServiceError(400, "the body must be a JSON object");
  SessionRequest request;
  for (const auto& [key, value] : json.items()) {
    if (key == "source") {
      if (!value.is_string()) throw ServiceError(400, "\"source\" must be a string");
      request.source = value.get<std::string>();
    } else if (key == "set") {
      if (!value.is_object())
        throw ServiceError(400, "\"set\" must be an object of configuration keys and values");
      for (const auto& [k, v] : value.items()) {
        std::string text;
        if (v.is_string())
          text = v.get<std::string>();
        else if (v.is_boolean())
          text = v.get<bool>() ? "true" : "false";
        else if (v.is_number())
          text = v.dump();
        else
          throw ServiceError(400, "\"set\": the value of " + k +
                                      " must be a string, number or "
                                      "boolean");
        request.sets.push_back(k + "=" + text);
      }
    } else if (key == "realtime") {
      if (!value.is_boolean()) throw ServiceError(400, "\"realtime\" must be true or false");
      request.realtime = value.get<bool>();
    } else if (key == "frames") {
      if (!value.is_number_unsigned() || value.get<std::uint64_t>() == 0 ||
          value.get<std::uint64_t>() > (std::uint64_t{1} << 34))
        throw ServiceError(400, "\"frames\" must be a whole number from 1 to 17179869184");
      request.max_frames = value.get<std::size_t>();
    } else if (key == "loop") {
      if (!value.is_number_integer())
        throw ServiceError(400, "\"loop\" must be a whole number (the passes, as replay --loop)");
      request.loop = value.get<std::int64_t>();  // its range is checked with the source
    } else {
      throw ServiceError(400, "unknown key \"" + key +
                                  "\" (source, set, realtime, frames and loop are understood)");
    }
  }
  if (request.source.empty()) throw ServiceError(400, "\"source\" is missing");
  return request;
}

}  // namespace aoscan
