/// @file hud.cpp
/// @brief HUD text, the built-in 5x7 font and the overlay raster.
#include "render/hud.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

namespace aoscan {
namespace {

/// One glyph drawn as 7 rows of 5 characters ('#' = ink), designed for this project.
struct GlyphArt {
  char c;
  const char* rows[kGlyphHeight];
};

// clang-format off
constexpr GlyphArt kFontArt[] = {
  {' ', {".....", ".....", ".....", ".....", ".....", ".....", "....."}},
  {'A', {".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
  {'B', {"####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."}},
  {'C', {".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."}},
  {'D', {"####.", "#...#", "#...#", "#...#", "#...#", "#...#", "####."}},
  {'E', {"#####", "#....", "#....", "####.", "#....", "#....", "#####"}},
  {'F', {"#####", "#....", "#....", "####.", "#....", "#....", "#...."}},
  {'G', {".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"}},
  {'H', {"#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"}},
  {'I', {".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."}},
  {'J', {"..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."}},
  {'K', {"#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"}},
  {'L', {"#....", "#....", "#....", "#....", "#....", "#....", "#####"}},
  {'M', {"#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"}},
  {'N', {"#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"}},
  {'O', {".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
  {'P', {"####.", "#...#", "#...#", "####.", "#....", "#....", "#...."}},
  {'Q', {".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"}},
  {'R', {"####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"}},
  {'S', {".####", "#....", "#....", ".###.", "....#", "....#", "####."}},
  {'T', {"#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."}},
  {'U', {"#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."}},
  {'V', {"#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."}},
  {'W', {"#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."}},
  {'X', {"#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"}},
  {'Y', {"#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."}},
  {'Z', {"#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"}},
  {'0', {".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."}},
  {'1', {"..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."}},
  {'2', {".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"}},
  {'3', {"#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."}},
  {'4', {"...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."}},
  {'5', {"#####", "#....", "####.", "....#", "....#", "#...#", ".###."}},
  {'6', {"..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."}},
  {'7', {"#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."}},
  {'8', {".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."}},
  {'9', {".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."}},
  {'.', {".....", ".....", ".....", ".....", ".....", ".##..", ".##.."}},
  {',', {".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."}},
  {':', {".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."}},
  {'-', {".....", ".....", ".....", "#####", ".....", ".....", "....."}},
  {'+', {".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."}},
  {'=', {".....", ".....", "#####", ".....", "#####", ".....", "....."}},
  {'/', {"....#", "....#", "...#.", "..#..", ".#...", "#....", "#...."}},
  {'%', {"##..#", "##..#", "...#.", "..#..", ".#...", "#..##", "#..##"}},
  {'(', {"...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."}},
  {')', {".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."}},
  {'[', {".###.", ".#...", ".#...", ".#...", ".#...", ".#...", ".###."}},
  {']', {".###.", "...#.", "...#.", "...#.", "...#.", "...#.", ".###."}},
  {'<', {"...#.", "..#..", ".#...", "#....", ".#...", "..#..", "...#."}},
  {'>', {".#...", "..#..", "...#.", "....#", "...#.", "..#..", ".#..."}},
  {'_', {".....", ".....", ".....", ".....", ".....", ".....", "#####"}},
  {'?', {".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."}},
  {'!', {"..#..", "..#..", "..#..", "..#..", "..#..", ".....", "..#.."}},
  {'*', {".....", "..#..", "#.#.#", ".###.", "#.#.#", "..#..", "....."}},
  {'#', {".#.#.", ".#.#.", "#####", ".#.#.", "#####", ".#.#.", ".#.#."}},
  {'\'', {"..#..", "..#..", ".#...", ".....", ".....", ".....", "....."}},
};
// clang-format on

/// The art packed into bit rows, indexed by character code.
struct Font {
  std::array<std::array<std::uint8_t, kGlyphHeight>, 128> bits{};
  std::array<bool, 128> present{};
  Font() {
    for (const GlyphArt& art : kFontArt) {
      const int code = static_cast<unsigned char>(art.c);
      present[code] = true;
      for (int row = 0; row < kGlyphHeight; ++row) {
        std::uint8_t b = 0;
        for (int col = 0; col < kGlyphWidth; ++col)
          if (art.rows[row][col] == '#') b |= static_cast<std::uint8_t>(1u << (4 - col));
        bits[code][row] = b;
      }
    }
  }
};

const Font& font() {
  static const Font f;
  return f;
}

constexpr Rgba8 kBoxColour{0, 0, 0, 160};
constexpr Rgba8 kTextColour{255, 255, 255, 255};

std::string format(const char* fmt, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, fmt, value);
  return buffer;
}

}  // namespace

const std::uint8_t* font_glyph(char c) {
  int code = static_cast<unsigned char>(c);
  if (code >= 'a' && code <= 'z') code += 'A' - 'a';
  if (code >= 128 || !font().present[code]) return nullptr;
  return font().bits[code].data();
}

std::vector<std::string> hud_lines(const ViewFrame* frame, View view, double render_fps) {
  std::vector<std::string> lines;
  // The colour views of a frame without colour show the shaded view: say so.
  const bool no_colour = frame && frame->colour.empty() &&
                         (view == View::kColour || view == View::kColourMvao);
  lines.push_back(std::string("view ") + view_name(view) + (no_colour ? " (no colour: shaded)" : "") +
                  " (v)   draw " + format("%.0f fps", render_fps));
  if (!frame) {
    lines.push_back("waiting for the first frame");
    return lines;
  }
  const HudStats& s = frame->hud;
  lines.push_back("fusion " + format("%.1f fps", s.fps) + "   frame " +
                  std::to_string(frame->sequence));
  lines.push_back("tracking " + frame->tracking_state +
                  (s.integration_paused ? "   integration paused" : ""));
  lines.push_back("processed " + std::to_string(s.frames_processed) + "   dropped " +
                  std::to_string(s.frames_dropped));
  for (const auto& [name, ms] : s.stage_ms) lines.push_back(name + format(" %.1f ms", ms));
  lines.push_back("r reset  space pause  s save  q quit");
  return lines;
}

void render_text_overlay(const std::vector<std::string>& lines, int scale, Image<Rgba8>& out) {
  scale = std::max(scale, 1);
  std::size_t columns = 0;
  for (const std::string& line : lines) columns = std::max(columns, line.size());
  const int cols = static_cast<int>(columns) + 2;       // one empty cell each side
  const int rows = static_cast<int>(lines.size()) + 1;  // half a cell above and below
  out.resize(cols * kCellWidth * scale, rows * kCellHeight * scale, kBoxColour);
  const std::uint8_t* fallback = font_glyph('?');
  for (std::size_t li = 0; li < lines.size(); ++li) {
    const int top = (kCellHeight / 2 + static_cast<int>(li) * kCellHeight + 1) * scale;
    for (std::size_t ci = 0; ci < lines[li].size(); ++ci) {
      const std::uint8_t* glyph = font_glyph(lines[li][ci]);
      if (!glyph) glyph = fallback;
      const int left = (static_cast<int>(ci) + 1) * kCellWidth * scale;
      for (int gy = 0; gy < kGlyphHeight; ++gy)
        for (int gx = 0; gx < kGlyphWidth; ++gx) {
          if (!(glyph[gy] & (1u << (4 - gx)))) continue;
          for (int sy = 0; sy < scale; ++sy)
            for (int sx = 0; sx < scale; ++sx)
              out(left + gx * scale + sx, top + gy * scale + sy) = kTextColour;
        }
    }
  }
}

void blend_overlay(const Image<Rgba8>& overlay, int x0, int y0, Image<Rgb8>& image) {
  const auto mix = [](std::uint8_t src, std::uint8_t dst, float a) {
    const float c = (static_cast<float>(src) * a + static_cast<float>(dst) * (1.0f - a)) / 255.0f;
    return static_cast<std::uint8_t>(std::floor(std::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f));
  };
  for (int y = 0; y < overlay.height(); ++y) {
    for (int x = 0; x < overlay.width(); ++x) {
      if (!image.contains(x0 + x, y0 + y)) continue;
      const Rgba8 s = overlay(x, y);
      const float a = static_cast<float>(s.a) / 255.0f;
      Rgb8& d = image(x0 + x, y0 + y);
      d = {mix(s.r, d.r, a), mix(s.g, d.g, a), mix(s.b, d.b, a)};
    }
  }
}

}  // namespace aoscan
