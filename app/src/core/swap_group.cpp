#include "kumite/app/swap_group.hpp"

#include <fmt/format.h>

namespace kumite::app {

bool has_extension(std::string_view extensions, std::string_view name) {
  if (name.empty()) return false;
  for (std::size_t at = extensions.find(name); at != std::string_view::npos; at = extensions.find(name, at + 1)) {
    const bool starts = at == 0 || extensions[at - 1] == ' ';
    const std::size_t end = at + name.size();
    const bool ends = end == extensions.size() || extensions[end] == ' ';
    if (starts && ends) return true;
  }
  return false;
}

std::optional<std::string> swap_group_refusal(const SwapGroupRequest& r, const SwapGroupOffer& o) {
  const std::string asked = fmt::format("node {}: swap_group = {}{} asked for, but ", r.node, r.group,
                                        r.barrier ? fmt::format(", swap_barrier = {}", *r.barrier) : "");
  const std::string after =
      ": its walls swap on the cluster's software barrier alone (they can differ by up to one refresh)";
  if (!o.x11) return asked + "its windows are not X11 windows with GLX contexts (Wayland?)" + after;
  if (!o.extension)
    return asked + "the display does not offer GLX_NV_swap_group (an NVIDIA professional driver offers it)" + after;
  if (static_cast<unsigned>(r.group) > o.max_groups)
    return asked + fmt::format("the driver offers {} swap group(s)", o.max_groups) + after;
  if (r.barrier && static_cast<unsigned>(*r.barrier) > o.max_barriers)
    return asked + fmt::format("the driver offers {} swap barrier(s) (a frame-lock board provides them)", o.max_barriers) +
           after;
  return std::nullopt;
}

}  // namespace kumite::app
