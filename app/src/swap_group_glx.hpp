#pragma once
// GLX_NV_swap_group for GLFW's windows (swap_group_glx.cpp: the GLX headers stay there).
#include <vector>

#include "kumite/app/swap_group.hpp"

struct GLFWwindow;

namespace kumite::app {

/// Joins `windows` to `request`'s group (and binds its barrier) when the display offers
/// GLX_NV_swap_group; logs one line either way (swap_group_refusal's when not offered). Returns
/// what the display offered.
SwapGroupOffer join_swap_group(const std::vector<GLFWwindow*>& windows, const SwapGroupRequest& request);

}  // namespace kumite::app
