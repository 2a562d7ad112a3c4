// What a render node's walls show when its master is gone: "waiting for master" in letters
// across the middle of each wall (the 5x7 notice font, drawn with scissored clears).
#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "kumite/app/headless.hpp"
#include "kumite/app/renderer.hpp"
#include "kumite/app/stereo.hpp"
#include "kumite/app/wall_notice.hpp"

using namespace kumite::app;

namespace {

bool near(const std::uint8_t* px, const float (&c)[3]) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(static_cast<int>(px[k]) - static_cast<int>(c[k] * 255.0f + 0.5f)) > 2) return false;
  return true;
}

struct Drawn {
  int w = 0, h = 0;
  std::vector<std::uint8_t> before, after;  // top row first
  const std::uint8_t* px(const std::vector<std::uint8_t>& img, int x, int gl_y) const {
    return &img[(static_cast<std::size_t>(h - 1 - gl_y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x)) * 4];
  }
};

/// The empty room from the middle of a 3 m room, then `text` over it in `mode`.
Drawn draw(int w, int h, StereoMode mode, std::string_view text) {
  HeadlessContext context;
  const WallFrame front = wall_frame({-1.5, 0, -1.5}, {1.5, 0, -1.5}, {-1.5, 2.4, -1.5});
  const WallFrame walls[] = {front};
  Renderer renderer(walls);
  OffscreenTarget target(w, h);
  target.bind();
  const EyeView view = off_axis(front, {0.0, 1.7, 0.0}, 0.05, 100.0);
  renderer.clear(0, 0, w, h);
  renderer.draw(view, {});
  Drawn d{w, h, {}, {}};
  target.read(d.before);
  draw_notice_stereo(mode, {0, 0, w, h}, text);
  target.read(d.after);
  return d;
}

/// Checks one notice in the box (x0, y0, bw, bh: GL coordinates): its band's rows hold only
/// the band's and the letters' colours, exactly the font's lit pixels in letters, and the rows
/// above and below it are as they were.
void expect_notice(const Drawn& d, int x0, int y0, int bw, int bh, std::string_view text) {
  const NoticeLayout l = notice_layout(text.size(), bw, bh);
  ASSERT_GE(l.scale, 2) << "a wall this size shows letters larger than the font";
  std::size_t letters = 0, other = 0, changed_outside = 0;
  for (int y = y0; y < y0 + bh; ++y)
    for (int x = x0; x < x0 + bw; ++x) {
      const std::uint8_t* a = d.px(d.after, x, y);
      const bool in_band = y >= y0 + l.band_y && y < y0 + l.band_y + l.band_h;
      if (!in_band) {
        const std::uint8_t* b = d.px(d.before, x, y);
        if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) ++changed_outside;
        continue;
      }
      if (near(a, kNoticeText)) {
        ++letters;
        const bool in_line = x >= x0 + l.text_x && x < x0 + l.text_x + l.text_w && y >= y0 + l.text_y &&
                             y < y0 + l.text_y + l.text_h;
        EXPECT_TRUE(in_line) << "a letter's pixel outside the line at " << x << "," << y;
      } else if (!near(a, kNoticeBand)) {
        ++other;
      }
    }
  EXPECT_EQ(changed_outside, 0u);
  EXPECT_EQ(other, 0u);
  EXPECT_EQ(letters, notice_pixels_lit(text) * static_cast<std::size_t>(l.scale * l.scale));
}

}  // namespace

TEST(WallNotice, LettersAcrossTheMiddleOnADarkBandTheRestOfTheWallKept) {
  const std::string_view text = "waiting for master";
  EXPECT_EQ(notice_pixels_lit("I"), 11u);  // 3 + 5 x 1 + 3
  EXPECT_GT(notice_pixels_lit(text), notice_pixels_lit("WAITING"));
  const Drawn d = draw(480, 270, StereoMode::mono, text);
  expect_notice(d, 0, 0, 480, 270, text);
  // The line sits in the middle, 80 % of the width at most.
  const NoticeLayout l = notice_layout(text.size(), 480, 270);
  EXPECT_LE(l.text_w, 480 * 4 / 5);
  EXPECT_NEAR(l.band_y + l.band_h / 2, 135, 1);
}

TEST(WallNotice, SideBySideStereoShowsItToEachEye) {
  const std::string_view text = "waiting for master";
  const Drawn d = draw(960, 270, StereoMode::side_by_side, text);
  expect_notice(d, 0, 0, 480, 270, text);
  expect_notice(d, 480, 0, 480, 270, text);
}

TEST(WallNotice, AnUnknownCharacterIsAQuestionMarkAndTinyWallsClipTheLine) {
  EXPECT_EQ(notice_pixels_lit("~"), notice_pixels_lit("?"));
  EXPECT_EQ(notice_pixels_lit("a"), notice_pixels_lit("A"));
  // 32x18 (a test's size): scale 1, the line wider than the wall, clipped; nothing outside it.
  const NoticeLayout l = notice_layout(18, 32, 18);
  EXPECT_EQ(l.scale, 1);
  EXPECT_GT(l.text_w, 32);
  const Drawn d = draw(32, 18, StereoMode::mono, "waiting for master");
  std::size_t changed = 0;
  for (int y = 0; y < 18; ++y)
    for (int x = 0; x < 32; ++x) {
      const auto* a = d.px(d.after, x, y);
      const auto* b = d.px(d.before, x, y);
      if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) {
        ++changed;
        EXPECT_TRUE(y >= l.band_y && y < l.band_y + l.band_h) << x << "," << y;
      }
    }
  EXPECT_GT(changed, 32u);  // the band at least
}
