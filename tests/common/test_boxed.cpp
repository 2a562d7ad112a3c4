// Boxed<T> (common/boxed.hpp): value semantics for a T that may be incomplete where the box is
// declared, copied, compared and destroyed (app/config.hpp holds the fighter's tunables so).
#include "kumite/common/boxed.hpp"

#include <string>
#include <utility>

#include <gtest/gtest.h>

namespace {

struct Tunables {
  double walk_speed_mps = 1.2;
  std::string preset = "none";
  bool operator==(const Tunables&) const = default;
};

// A struct as app/config.hpp has them: defaulted ==, copied whole.
struct Section {
  kumite::Boxed<Tunables> tunables;
  int seed = 1;
  bool operator==(const Section&) const = default;
};

TEST(Boxed, AnEmptyBoxReadsAsTheDefaultAndEqualsOne) {
  const Section s;
  EXPECT_EQ(s.tunables->walk_speed_mps, 1.2);
  EXPECT_EQ(s.tunables->preset, "none");
  Section written;
  written.tunables->walk_speed_mps = 1.2;  // allocated here, the default value kept
  EXPECT_EQ(s, written);
  EXPECT_EQ(written, s);
  written.tunables->walk_speed_mps = 0.5;
  EXPECT_NE(s, written);
  EXPECT_NE(written, s);
}

TEST(Boxed, CopiesAreDeepAndCompareByValue) {
  Section a;
  a.tunables->preset = "defensive_skilled";
  Section b = a;
  EXPECT_EQ(a, b);
  b.tunables->preset = "aggressive_unskilled";
  EXPECT_EQ(a.tunables->preset, "defensive_skilled") << "a copy's write reached the original";
  EXPECT_NE(a, b);
  b = a;
  EXPECT_EQ(b.tunables->preset, "defensive_skilled");
  b.tunables->walk_speed_mps = 2;
  EXPECT_EQ(a.tunables->walk_speed_mps, 1.2);
}

TEST(Boxed, MovedFromIsEmptyAndTakesAValueAgain) {
  Section a;
  a.tunables->walk_speed_mps = 0.7;
  Section b = std::move(a);
  EXPECT_EQ(b.tunables->walk_speed_mps, 0.7);
  EXPECT_EQ(std::as_const(a).tunables->walk_speed_mps, 1.2);  // NOLINT(bugprone-use-after-move): an empty box reads as the default
  a.tunables = Tunables{0.3, "x"};
  EXPECT_EQ(a.tunables->walk_speed_mps, 0.3);
  EXPECT_EQ(a.tunables->preset, "x");
  Section c;
  c = std::move(b);
  EXPECT_EQ(c.tunables->walk_speed_mps, 0.7);
}

}  // namespace
