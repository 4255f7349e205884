/// @file hud_test.cpp
/// @brief The HUD: its lines, the font covers them, the overlay raster and the CPU blend.
#include "render/hud.h"

#include <gtest/gtest.h>

#include "render/render_test_util.h"

namespace aoscan {
namespace {

TEST(Hud, LinesShowTheNumbers) {
  const ViewFrame f = testing::sphere_wall_frame(16, 12);
  const std::vector<std::string> lines = hud_lines(&f, View::kSsao, 59.6);
  std::string all;
  for (const auto& l : lines) all += l + "\n";
  EXPECT_NE(all.find("view ssao"), std::string::npos) << all;
  EXPECT_NE(all.find("60 fps"), std::string::npos) << all;
  EXPECT_NE(all.find("fusion 29.5 fps"), std::string::npos) << all;
  EXPECT_NE(all.find("tracking ok"), std::string::npos) << all;
  EXPECT_NE(all.find("dropped 1"), std::string::npos) << all;
  EXPECT_NE(all.find("preprocess 12.2 ms"), std::string::npos) << all;  // %.1f of 12.25
  EXPECT_NE(all.find("track 8.5 ms"), std::string::npos) << all;
  EXPECT_EQ(hud_lines(nullptr, View::kShaded, 0.0).size(), 2u);
}

TEST(Hud, ColourViewsOfAFrameWithoutColourSaySo) {
  ViewFrame f = testing::sphere_wall_frame(16, 12);
  for (View v : {View::kColour, View::kColourMvao, View::kShaded}) {
    EXPECT_EQ(hud_lines(&f, v, 30.0)[0].find("no colour"), std::string::npos) << view_name(v);
  }
  f.colour = Image<Rgb8>();
  EXPECT_NE(hud_lines(&f, View::kColour, 30.0)[0].find("view colour (no colour: shaded)"),
            std::string::npos);
  EXPECT_NE(hud_lines(&f, View::kColourMvao, 30.0)[0].find("(no colour: shaded)"),
            std::string::npos);
  EXPECT_EQ(hud_lines(&f, View::kMvao, 30.0)[0].find("no colour"), std::string::npos);
}

TEST(Hud, FontCoversEverythingTheHudWrites) {
  ViewFrame f = testing::sphere_wall_frame(16, 12);
  f.tracking_state = kTrackingLostState;
  f.hud.integration_paused = true;
  for (const bool colour : {true, false}) {
    if (!colour) f.colour = Image<Rgb8>();
    for (int v = 0; v < kViewCount; ++v)
      for (const std::string& line : hud_lines(&f, static_cast<View>(v), 12.0))
        for (char c : line) EXPECT_NE(font_glyph(c), nullptr) << "'" << c << "' in " << line;
  }
  for (char c = 'a'; c <= 'z'; ++c) EXPECT_EQ(font_glyph(c), font_glyph(static_cast<char>(c - 32)));
  for (char c = '0'; c <= '9'; ++c) EXPECT_NE(font_glyph(c), nullptr);
  EXPECT_EQ(font_glyph('\t'), nullptr);
  EXPECT_EQ(font_glyph(static_cast<char>(200)), nullptr);
}

TEST(Hud, GlyphsAreDistinct) {
  const std::string chars = "ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789.,:-+=/%()[]<>_?!*#'";
  for (std::size_t i = 0; i < chars.size(); ++i)
    for (std::size_t j = i + 1; j < chars.size(); ++j) {
      const std::uint8_t* a = font_glyph(chars[i]);
      const std::uint8_t* b = font_glyph(chars[j]);
      ASSERT_TRUE(a && b);
      EXPECT_FALSE(std::equal(a, a + kGlyphHeight, b)) << chars[i] << " vs " << chars[j];
    }
}

TEST(Hud, OverlayRaster) {
  Image<Rgba8> overlay;
  render_text_overlay({"I", "--"}, 2, overlay);
  // 2 + 2 columns of 6 px, 2 + 1 rows of 9 px, all doubled.
  EXPECT_EQ(overlay.width(), 4 * kCellWidth * 2);
  EXPECT_EQ(overlay.height(), 3 * kCellHeight * 2);
  const Rgba8 box{0, 0, 0, 160};
  const Rgba8 ink{255, 255, 255, 255};
  EXPECT_EQ(overlay(0, 0), box);
  // 'I' starts one cell in and half a cell (4 px) + 1 px down, at scale 2: its top bar is
  // columns 1..3 of the glyph.
  const int left = kCellWidth * 2;
  const int top = (kCellHeight / 2 + 1) * 2;
  EXPECT_EQ(overlay(left + 0, top), box);
  EXPECT_EQ(overlay(left + 2, top), ink);
  EXPECT_EQ(overlay(left + 3, top + 1), ink);
  EXPECT_EQ(overlay(left + 7, top), ink);
  EXPECT_EQ(overlay(left + 8, top), box);
  EXPECT_EQ(overlay(left + 4, top + 2 * 3), ink);  // the stem
  EXPECT_EQ(overlay(left + 2, top + 2 * 3), box);
  int ink_pixels = 0;
  for (int y = 0; y < overlay.height(); ++y)
    for (int x = 0; x < overlay.width(); ++x) ink_pixels += overlay(x, y) == ink;
  EXPECT_EQ(ink_pixels, 4 * (11 + 5 + 5));  // 'I' has 11 ink pixels, '-' 5 each
}

TEST(Hud, BlendMatchesGlBlending) {
  Image<Rgba8> overlay(2, 1);
  overlay(0, 0) = {0, 0, 0, 160};
  overlay(1, 0) = {255, 255, 255, 255};
  Image<Rgb8> image(4, 2, Rgb8{200, 100, 0});
  blend_overlay(overlay, 2, 1, image);
  EXPECT_EQ(image(0, 0), (Rgb8{200, 100, 0}));
  // 200 * (1 - 160/255) = 74.5 → 75 (rounded like the GL unorm conversion).
  EXPECT_EQ(image(2, 1), (Rgb8{75, 37, 0}));
  EXPECT_EQ(image(3, 1), (Rgb8{255, 255, 255}));
  blend_overlay(overlay, 3, 1, image);         // clipped at the right edge, no crash
  EXPECT_EQ(image(3, 1), (Rgb8{95, 95, 95}));  // 255 * (1 - 160/255)
}

}  // namespace
}  // namespace aoscan
