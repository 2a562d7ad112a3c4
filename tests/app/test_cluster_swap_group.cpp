// Hardware swap groups for a render node's windows ([[cluster.nodes]] swap_group,
// swap_barrier; GLX_NV_swap_group): what is asked for against what the display offers. The
// joining itself needs an NVIDIA professional driver; the line said when it is not offered is
// checked here, and under Xvfb (ClusterWindows.UnderXvfb) through the kumite binary.
#include <gtest/gtest.h>

#include "kumite/app/swap_group.hpp"

using namespace kumite::app;

TEST(SwapGroup, AnExtensionIsFoundByItsWholeName) {
  EXPECT_TRUE(has_extension("GLX_ARB_multisample GLX_NV_swap_group GLX_SGI_swap_control", "GLX_NV_swap_group"));
  EXPECT_TRUE(has_extension("GLX_NV_swap_group", "GLX_NV_swap_group"));
  EXPECT_FALSE(has_extension("GLX_NV_swap_groupX GLX_ARB_create_context", "GLX_NV_swap_group"));
  EXPECT_FALSE(has_extension("XGLX_NV_swap_group", "GLX_NV_swap_group"));
  EXPECT_FALSE(has_extension("", "GLX_NV_swap_group"));
}

TEST(SwapGroup, WhatIsNotOfferedIsOneLineSayingWhyAndWhatTheWallsDoInstead) {
  const SwapGroupRequest r{"front", 1, std::nullopt};
  const std::string tail = ": its walls swap on the cluster's software barrier alone (they can differ by up to one refresh)";
  EXPECT_EQ(swap_group_refusal(r, {false, false, 0, 0}),
            "node front: swap_group = 1 asked for, but its windows are not X11 windows with GLX contexts (Wayland?)" + tail);
  EXPECT_EQ(swap_group_refusal(r, {true, false, 0, 0}),
            "node front: swap_group = 1 asked for, but the display does not offer GLX_NV_swap_group (an NVIDIA "
            "professional driver offers it)" + tail);
  EXPECT_EQ(swap_group_refusal({"front", 2, std::nullopt}, {true, true, 1, 1}),
            "node front: swap_group = 2 asked for, but the driver offers 1 swap group(s)" + tail);
  EXPECT_EQ(swap_group_refusal({"front", 1, 1}, {true, true, 1, 0}),
            "node front: swap_group = 1, swap_barrier = 1 asked for, but the driver offers 0 swap barrier(s) (a "
            "frame-lock board provides them)" + tail);
  EXPECT_EQ(swap_group_refusal({"front", 1, 1}, {true, true, 1, 1}), std::nullopt);
  EXPECT_EQ(swap_group_refusal(r, {true, true, 1, 0}), std::nullopt);
}
