// A frame's fields are described once (kumite/app/frame_fields.hpp) and every walker goes over
// that description knowing no field by name: a field added there is recorded (states.bin's
// bytes and the session's state hashes), read back by a replay, logged (frames.jsonl) and
// diffed, with no other edit. Here a frame type of the test's own adds one, as a sparring
// fighter would add its guard; each check fails if its walker skipped the field.
#include <gtest/gtest.h>

#include <cstring>

#include "frame_walk.hpp"

using namespace kumite::app;

namespace {

/// A frame with one field more, added the way FrameData's own are: a member and one line of
/// description, with the frame version that adds it.
struct GuardedFrame : FrameData {
  double guard_height_m = 0;  ///< m above the floor: where the fighter holds its guard
};
constexpr int kGuardVersion = kFrameVersion + 1;

template <class V, class... T>
  requires AllOf<GuardedFrame, T...>
void describe(V& v, T&... x) {
  describe(v, as_base<FrameData>(x)...);
  v(Field{.name = "guard_height_m", .unit = Unit::m, .log = Log::plain, .hash = Hashed::fighter, .since = kGuardVersion},
    x.guard_height_m...);
}

template <class F>
std::string bytes_of(const F& frame, int version) {
  std::string s;
  walk::StringSink sink{s};
  walk::Writer<walk::StringSink> w{sink, version};
  describe(w, frame);
  return s;
}

GuardedFrame a_frame() {
  GuardedFrame f;
  f.frame = 7;
  f.time_s = 1.5;
  f.now = 11.5;
  f.views.resize(1);
  f.fighter.present = true;
  f.fighter.joints = {{0, 1, -1}};
  f.fighter.local_rotations = {glm::dquat(1, 0, 0, 0)};
  FrameEvent hit;
  hit.type = EventType::hit;
  hit.distance_m = 0.01;
  hit.time_s = 1.5;
  f.events.push_back(hit);
  f.guard_height_m = 1.25;
  return f;
}

}  // namespace

TEST(FrameFields, AFieldAddedToTheDescriptionIsRecordedReplayedLoggedAndDiffed) {
  const GuardedFrame f = a_frame();
  // Recorded: its 8 bytes follow the frame's, exactly.
  const std::string base = bytes_of(static_cast<const FrameData&>(f), kFrameVersion);
  const std::string all = bytes_of(f, kGuardVersion);
  ASSERT_EQ(all.size(), base.size() + sizeof(double));
  EXPECT_EQ(all.substr(0, base.size()), base);
  double written = 0;
  std::memcpy(&written, all.data() + base.size(), sizeof written);
  EXPECT_EQ(written, 1.25);

  // Replayed: read back whole, the field with it; a file of the version before reads too,
  // the field then at its default.
  GuardedFrame back;
  walk::Reader r{all, kGuardVersion};
  describe(r, back);
  EXPECT_TRUE(r.ok && r.p.empty());
  EXPECT_EQ(back.guard_height_m, 1.25);
  EXPECT_FALSE(walk::first_difference(f, back, kGuardVersion)) << *walk::first_difference(f, back, kGuardVersion);
  GuardedFrame old;
  walk::Reader r_old{base, kFrameVersion};
  describe(r_old, old);
  EXPECT_TRUE(r_old.ok && r_old.p.empty());
  EXPECT_EQ(old.guard_height_m, 0);
  EXPECT_EQ(old.events.at(0).type, EventType::hit);

  // Hashed in its group (fighter), and only in a session of its version.
  GuardedFrame moved = f;
  moved.guard_height_m = 1.3;
  const auto h = walk::hash(f, kGuardVersion), h_moved = walk::hash(moved, kGuardVersion);
  for (std::size_t k = 0; k < h.size(); ++k)
    EXPECT_EQ(h[k] != h_moved[k], kHashedNames[k] == "fighter") << kHashedNames[k];
  EXPECT_EQ(walk::hash(f, kFrameVersion), walk::hash(moved, kFrameVersion));

  // Diffed: named, with both values; a recording of the version before does not compare it.
  const auto d = walk::first_difference(f, moved, kGuardVersion);
  ASSERT_TRUE(d);
  EXPECT_EQ(*d, "guard_height_m: recorded 1.25, now 1.3");
  EXPECT_FALSE(walk::first_difference(f, moved, kFrameVersion));

  // Logged under its name, beside the frame's own fields.
  const auto j = walk::log_object(f, {"front"}, true);
  ASSERT_TRUE(j.contains("guard_height_m")) << j.dump();
  EXPECT_EQ(j["guard_height_m"].get<double>(), 1.25);
  EXPECT_EQ(j["events"][0]["type"], "hit");
  EXPECT_EQ(j["events"][0]["distance_m"].get<double>(), 0.01);
  EXPECT_TRUE(j["walls"].contains("front"));
}

// The diff names a frame's own fields by their path: a joint by its skeleton's name, an event
// by its index, a field of a fighter's event inside it.
TEST(FrameFields, TheDiffNamesTheFieldByItsPath) {
  FrameData a = a_frame();
  auto sk = std::make_shared<FighterSkeleton>();
  sk->joint_names = {"Hips"};
  sk->parents = {-1};
  a.fighter.skeleton = sk;
  FrameData b = a;
  b.fighter.joints[0].y += 0.004;
  EXPECT_EQ(walk::first_difference(a, b).value_or(""),
            "fighter.joints[Hips]: recorded (0.0000, 1.0000, -1.0000) m, now (0.0000, 1.0040, -1.0000) m, 4.0 mm apart");
  b = a;
  b.events[0].fighter.segment = 12;
  EXPECT_EQ(walk::first_difference(a, b).value_or(""), "events[0].fighter.segment: recorded -1, now 12");
  b = a;
  b.events[0].type = EventType::dodged;
  EXPECT_EQ(walk::first_difference(a, b).value_or(""), "events[0].type: recorded hit, now dodged");
}
