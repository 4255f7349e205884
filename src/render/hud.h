/// @file hud.h
/// @brief The heads-up display: its text lines, drawn with a built-in 5x7 bitmap font into an RGBA
/// overlay that the GL view blends over the picture (and the CPU can blend the same way).
///
/// Why a built-in font rather than Dear ImGui: Debian bookworm ships no libimgui-dev, and the HUD
/// is a few lines of static text that need no widgets; a 60-glyph table keeps the render module
/// free of third-party code and makes the overlay testable on the CPU pixel for pixel.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image.h"
#include "render/view_frame.h"

namespace aoscan {

struct Rgba8 {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;
  std::uint8_t a = 0;
  bool operator==(const Rgba8& o) const { return r == o.r && g == o.g && b == o.b && a == o.a; }
};

/// Glyph box of the font (pixels at scale 1) and the cell including spacing.
inline constexpr int kGlyphWidth = 5;
inline constexpr int kGlyphHeight = 7;
inline constexpr int kCellWidth = 6;
inline constexpr int kCellHeight = 9;

/// The 5x7 bitmap of `c` (upper and lower case share glyphs), rows top to bottom, bit 4 = left
/// column; nullptr when the font has no glyph for it (drawn as '?').
const std::uint8_t* font_glyph(char c);

/// The HUD text for `frame` (may be null before the first frame) in `view`; `render_fps` is the
/// window's own redraw rate.
std::vector<std::string> hud_lines(const ViewFrame* frame, View view, double render_fps);

/// Draws `lines` at `scale` (>= 1) into `out` (resized): a translucent dark box with a 1-cell
/// margin behind opaque white text.
void render_text_overlay(const std::vector<std::string>& lines, int scale, Image<Rgba8>& out);

/// Blends `overlay` onto `image` with its top-left corner at pixel (x0, y0) like GL's
/// (SRC_ALPHA, ONE_MINUS_SRC_ALPHA) blending: c = src * a + dst * (1 - a), a = alpha / 255.
void blend_overlay(const Image<Rgba8>& overlay, int x0, int y0, Image<Rgb8>& image);

}  // namespace aoscan
