// GLX_NV_swap_group for the windows GLFW made: in a translation unit of its own, as the GLX and
// Xlib headers (GL/gl.h, macros such as None and Bool) do not mix with the core-profile header
// the renderer uses.
#include "swap_group_glx.hpp"

#include <GL/glx.h>
#include <X11/Xlib.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

// GLFW's native access (GLFW 3.3, X11 build), declared here: glfw3native.h with
// GLFW_EXPOSE_NATIVE_X11 also includes the XRandR header, which the build does not need.
extern "C" {
Display* glfwGetX11Display(void);
Window glfwGetX11Window(GLFWwindow* window);
GLXWindow glfwGetGLXWindow(GLFWwindow* window);
}

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace kumite::app {

namespace {
using JoinSwapGroup = Bool (*)(Display*, GLXDrawable, GLuint);
using BindSwapBarrier = Bool (*)(Display*, GLuint, GLuint);
using QueryMaxSwapGroups = Bool (*)(Display*, int, GLuint*, GLuint*);

template <typename F>
F proc(const char* name) {
  return reinterpret_cast<F>(glXGetProcAddressARB(reinterpret_cast<const GLubyte*>(name)));
}
}  // namespace

SwapGroupOffer join_swap_group(const std::vector<GLFWwindow*>& windows, const SwapGroupRequest& r) {
  SwapGroupOffer offer;
  Display* dpy = glfwGetX11Display();  // NULL (and a GLFW error) where GLFW is not on X11
  offer.x11 = dpy != nullptr && !windows.empty();
  if (offer.x11) {
    const char* ext = glXQueryExtensionsString(dpy, DefaultScreen(dpy));
    offer.extension = ext && has_extension(ext, "GLX_NV_swap_group");
  }
  const auto join = offer.extension ? proc<JoinSwapGroup>("glXJoinSwapGroupNV") : nullptr;
  const auto bind = offer.extension ? proc<BindSwapBarrier>("glXBindSwapBarrierNV") : nullptr;
  const auto query = offer.extension ? proc<QueryMaxSwapGroups>("glXQueryMaxSwapGroupsNV") : nullptr;
  if (offer.extension && !(join && bind && query)) offer.extension = false;
  if (offer.extension) {
    GLuint groups = 0, barriers = 0;
    if (query(dpy, DefaultScreen(dpy), &groups, &barriers)) {
      offer.max_groups = groups;
      offer.max_barriers = barriers;
    }
  }
  if (const auto why = swap_group_refusal(r, offer)) {
    spdlog::warn("{}", *why);
    return offer;
  }
  for (GLFWwindow* w : windows) {
    GLXDrawable d = glfwGetGLXWindow(w);
    if (!d) d = glfwGetX11Window(w);
    if (!join(dpy, d, static_cast<GLuint>(r.group))) {
      spdlog::warn("node {}: glXJoinSwapGroupNV(group {}) failed for a window: its walls swap on the cluster's "
                   "software barrier alone (they can differ by up to one refresh)",
                   r.node, r.group);
      return offer;
    }
  }
  if (r.barrier && !bind(dpy, static_cast<GLuint>(r.group), static_cast<GLuint>(*r.barrier))) {
    spdlog::warn("node {}: glXBindSwapBarrierNV(group {}, barrier {}) failed: its windows swap together, not with "
                 "the other machines' (no frame lock?)",
                 r.node, r.group, *r.barrier);
    return offer;
  }
  spdlog::info("node {}: its {} window(s) in GLX_NV_swap_group group {}{}", r.node, windows.size(), r.group,
               r.barrier ? fmt::format(", bound to swap barrier {}", *r.barrier) : "");
  return offer;
}

}  // namespace kumite::app
