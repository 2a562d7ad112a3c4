#pragma once
// The supervisor console (Dear ImGui in its own GLFW window): buttons and keys for orders,
// the key map, tracking and camera status, the fighter, last order and outcome, problems,
// frame rate, and a top view of the room.
#include <optional>
#include <string_view>

#include "kumite/app/installation.hpp"

struct GLFWwindow;

namespace kumite::app {

/// Applies the key map: an order for the installation, or quit. Unbound keys do nothing.
void handle_key(Installation& installation, int glfw_key);

class Console {
 public:
  Console(GLFWwindow* window, StereoMode mode);
  ~Console();
  Console(const Console&) = delete;
  Console& operator=(const Console&) = delete;
  /// Draws the console for `frame`. `orders`: what its buttons order (nullptr: a replay, whose
  /// frames are the recording's: the buttons are shown, greyed).
  void frame(const Installation& installation, const FrameData& frame, Installation* orders);
  void swap();
  GLFWwindow* window() const { return window_; }

 private:
  GLFWwindow* window_;
  StereoMode mode_;
};

}  // namespace kumite::app
