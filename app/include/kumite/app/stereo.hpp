#pragma once
// One wall into one viewport in one stereo mode (the current GL context's back buffer).
#include <array>
#include <string_view>

#include "kumite/app/config.hpp"
#include "kumite/app/renderer.hpp"

namespace kumite::app {

/// Pixels in the framebuffer, from its lower-left corner (OpenGL).
struct Viewport {
  int x = 0, y = 0, width = 0, height = 0;
};

/// Draws both eyes of one wall as `mode` says: quad_buffer into GL_BACK_LEFT/RIGHT,
/// side_by_side (left eye on the left half), top_bottom (left eye on top), anaglyph (left eye
/// red, right eye green+blue), mono (the first view only).
void draw_wall_stereo(Renderer& renderer, StereoMode mode, const Viewport& viewport,
                      const std::array<EyeView, 2>& views, std::span<const DrawItem> items);

/// `text` across the middle of each eye's part of the wall's viewport as `mode` divides it
/// (quad_buffer: both back buffers), over what draw_wall_stereo drew.
void draw_notice_stereo(StereoMode mode, const Viewport& viewport, std::string_view text);

}  // namespace kumite::app
