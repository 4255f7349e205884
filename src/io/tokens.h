/// @file tokens.h
/// @brief Splitting a text line into whitespace-separated tokens (TUM lists, ASCII PLY).
#pragma once

#include <string_view>
#include <vector>

namespace aoscan {

/// Whitespace-separated tokens of one line (spaces, tabs, a trailing '\r'); views into `line`.
inline std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

}  // namespace aoscan
