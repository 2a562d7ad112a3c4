#include "kumite/app/stereo.hpp"

#include "gl.hpp"
#include "kumite/app/wall_notice.hpp"

namespace kumite::app {

void draw_wall_stereo(Renderer& r, StereoMode mode, const Viewport& v,
                      const std::array<EyeView, 2>& views, std::span<const DrawItem> items) {
  auto eye = [&](int x, int y, int w, int h, int e) {
    r.clear(x, y, w, h);
    r.draw(views[static_cast<std::size_t>(e)], items);
  };
  switch (mode) {
    case StereoMode::mono:
      eye(v.x, v.y, v.width, v.height, 0);
      break;
    case StereoMode::side_by_side: {
      const int half = v.width / 2;
      eye(v.x, v.y, half, v.height, 0);
      eye(v.x + half, v.y, v.width - half, v.height, 1);
      break;
    }
    case StereoMode::top_bottom: {
      const int half = v.height / 2;
      eye(v.x, v.y + (v.height - half), v.width, half, 0);
      eye(v.x, v.y, v.width, v.height - half, 1);
      break;
    }
    case StereoMode::anaglyph:
      r.clear(v.x, v.y, v.width, v.height);
      glColorMask(GL_TRUE, GL_FALSE, GL_FALSE, GL_TRUE);
      r.draw(views[0], items);
      glEnable(GL_SCISSOR_TEST);
      glScissor(v.x, v.y, v.width, v.height);
      glClear(GL_DEPTH_BUFFER_BIT);
      glDisable(GL_SCISSOR_TEST);
      glColorMask(GL_FALSE, GL_TRUE, GL_TRUE, GL_TRUE);
      r.draw(views[1], items);
      glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
      break;
    case StereoMode::quad_buffer:
      glDrawBuffer(GL_BACK_LEFT);
      eye(v.x, v.y, v.width, v.height, 0);
      glDrawBuffer(GL_BACK_RIGHT);
      eye(v.x, v.y, v.width, v.height, 1);
      glDrawBuffer(GL_BACK);
      break;
  }
}

void draw_notice_stereo(StereoMode mode, const Viewport& v, std::string_view text) {
  if (text.empty()) return;
  switch (mode) {
    case StereoMode::side_by_side: {
      const int half = v.width / 2;
      draw_wall_notice(text, v.x, v.y, half, v.height);
      draw_wall_notice(text, v.x + half, v.y, v.width - half, v.height);
      break;
    }
    case StereoMode::top_bottom: {
      const int half = v.height / 2;
      draw_wall_notice(text, v.x, v.y + (v.height - half), v.width, half);
      draw_wall_notice(text, v.x, v.y, v.width, v.height - half);
      break;
    }
    case StereoMode::quad_buffer:
      glDrawBuffer(GL_BACK);  // both eyes' back buffers
      draw_wall_notice(text, v.x, v.y, v.width, v.height);
      break;
    case StereoMode::anaglyph:  // the letters in both colours: seen with either eye
    case StereoMode::mono:
      draw_wall_notice(text, v.x, v.y, v.width, v.height);
      break;
  }
}

}  // namespace kumite::app
