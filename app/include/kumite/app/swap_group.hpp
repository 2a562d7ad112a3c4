#pragma once
// Hardware swap groups (GLX_NV_swap_group, NVIDIA Quadro / RTX professional drivers): the
// windows of a group swap together, and a group bound to a swap barrier swaps together with the
// groups of other machines on the same frame-lock (Quadro Sync) network. A render node joins
// the group its [[cluster.nodes]] entry asks for (swap_group, swap_barrier), when the display
// offers the extension; when it does not, it says so in one line and its walls swap on the
// cluster's software barrier alone.
#include <optional>
#include <string>
#include <string_view>

namespace kumite::app {

struct SwapGroupRequest {
  std::string node;                ///< the node's name, for the lines
  int group = 0;                   ///< 1.. (swap_group)
  std::optional<int> barrier;      ///< 1.. (swap_barrier), none: the group is not bound
};

/// What the display offers: the extension, and its limits (glXQueryMaxSwapGroupsNV).
struct SwapGroupOffer {
  bool x11 = false;                ///< the windows are X11 windows with GLX contexts
  bool extension = false;          ///< GLX_NV_swap_group in glXQueryExtensionsString
  unsigned max_groups = 0, max_barriers = 0;
};

/// Whether `request` can be had from `offer`: nullopt when it can, else the one line that says
/// why not ("node front: swap_group = 1 asked for, but the display does not offer
/// GLX_NV_swap_group (...): ...").
std::optional<std::string> swap_group_refusal(const SwapGroupRequest& request, const SwapGroupOffer& offer);

/// Whether `extensions` (a GLX extension string: names separated by spaces) names `name`.
bool has_extension(std::string_view extensions, std::string_view name);

}  // namespace kumite::app
