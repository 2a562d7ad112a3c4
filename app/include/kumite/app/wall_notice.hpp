#pragma once
// A line of text across a wall: what a wall shows when it has nothing of its own to say (a
// render node waiting for its master). Drawn with scissored clears in a built-in 5x7 pixel
// font: no shader, no buffer, no font file, so any GL context draws it (headless EGL, a
// window), over whatever the wall shows.
#include <cstdint>
#include <string_view>
#include <vector>

namespace kumite::app {

/// The notice's colours (RGB 0..1): the band across the wall and the letters.
inline constexpr float kNoticeBand[3] = {0.05f, 0.05f, 0.07f};
inline constexpr float kNoticeText[3] = {1.0f, 0.78f, 0.2f};

/// Where the notice's pixels go in a viewport of `width` x `height`: the band's rows (from the
/// viewport's bottom) and the letters' scale (screen pixels per font pixel). Pure arithmetic:
/// the tests check a drawn image against it.
struct NoticeLayout {
  int scale = 1;                ///< pixels per font pixel (at least 1)
  int band_y = 0, band_h = 0;   ///< the band across the whole width, rows from the bottom
  int text_x = 0, text_y = 0;   ///< the first letter's lower-left pixel
  int text_w = 0, text_h = 0;   ///< the line's size in pixels
};
NoticeLayout notice_layout(std::size_t letters, int width, int height);

/// The 5x7 font pixels lit for `text` (upper-cased; A-Z, 0-9, space and . , : - ( ) / ' ! ? #;
/// any other character is drawn as '?'): their count, for the tests.
std::size_t notice_pixels_lit(std::string_view text);

/// Draws `text` centred on a dark band across the middle of the viewport (x, y, width, height:
/// GL window coordinates of the bound framebuffer). Leaves the GL state as it found it (the
/// scissor, the clear colour, the colour mask).
void draw_wall_notice(std::string_view text, int x, int y, int width, int height);

}  // namespace kumite::app
