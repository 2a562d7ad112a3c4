// Headless rendering: a synthetic stick figure (test data made here, not a fighter: joints
// placed by hand) drawn on the front wall must show up in the character's colour where its
// projection says, and nowhere else; the target sphere shows in red. Each stereo mode puts
// each eye's image where it says (quad-buffer needs a stereo context: none here). The PNG
// writer thread writes what it is given, and in real time drops rather than waits.
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "kumite/app/headless.hpp"
#include "kumite/app/renderer.hpp"
#include "kumite/app/scene.hpp"
#include "kumite/app/stereo.hpp"
#include "kumite/content/fighter.hpp"

// Mesa keeps some allocations for the life of the process; they are not ours.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libEGL_mesa\nleak:libgallium\nleak:libGLX_mesa\nleak:swrast_dri\nleak:libLLVM\n"
         "leak:libglapi\nleak:libEGL.so\nleak:libOpenGL\n";
}

using namespace kumite::app;

namespace {

struct StickFigure {
  std::vector<Eigen::Vector3d> joints;
  std::vector<int> parents;
  std::vector<float> radii;
};

/// A 1.75 m figure standing at (x, 0, z): pelvis, chest, head, two arms, two legs.
StickFigure stick_figure(double x, double z) {
  StickFigure s;
  auto add = [&](double jx, double jy, double jz, int parent, float r) {
    s.joints.emplace_back(x + jx, jy, z + jz);
    s.parents.push_back(parent);
    s.radii.push_back(r);
  };
  add(0, 1.0, 0, -1, 0.10f);      // 0 pelvis
  add(0, 1.45, 0, 0, 0.12f);      // 1 chest
  add(0, 1.68, 0, 1, 0.10f);      // 2 head
  add(-0.2, 1.4, 0, 1, 0.05f);    // 3 l shoulder
  add(-0.45, 1.2, 0.1, 3, 0.045f);// 4 l hand
  add(0.2, 1.4, 0, 1, 0.05f);     // 5 r shoulder
  add(0.45, 1.2, 0.1, 5, 0.045f); // 6 r hand
  add(-0.1, 0.5, 0, 0, 0.07f);    // 7 l knee
  add(-0.1, 0.05, 0, 7, 0.05f);   // 8 l foot
  add(0.1, 0.5, 0, 0, 0.07f);     // 9 r knee
  add(0.1, 0.05, 0, 9, 0.05f);    // 10 r foot
  return s;
}

kumite::content::FighterFrame frame_of(const StickFigure& s) {
  kumite::content::FighterFrame f;
  f.joints = s.joints;
  f.parents = s.parents;
  f.joint_radii_m = s.radii;
  return f;
}

struct Pixel {
  int x, y;  // top-left origin
};

Pixel project(const EyeView& v, const glm::dvec3& p, int w, int h) {
  const glm::dvec4 c = v.projection * v.view * glm::dvec4(p, 1.0);
  const double nx = c.x / c.w, ny = c.y / c.w;
  return {static_cast<int>((nx + 1) / 2 * w), static_cast<int>((1 - ny) / 2 * h)};
}

bool near_colour(const std::uint8_t* px, glm::vec3 base) {
  // Lit surfaces are the base colour scaled by 0.3..1.25: compare hue by channel ratios.
  const float r = px[0], g = px[1], b = px[2];
  const float m = std::max({r, g, b});
  if (m < 40) return false;
  const float bm = std::max({base.r, base.g, base.b});
  return std::abs(r / m - base.r / bm) < 0.12f && std::abs(g / m - base.g / bm) < 0.12f &&
         std::abs(b / m - base.b / bm) < 0.12f;
}

}  // namespace

TEST(Render, StickFigureAppearsWhereProjected) {
  HeadlessContext context;
  const WallFrame front = wall_frame({-1.5, 0, -1.5}, {1.5, 0, -1.5}, {-1.5, 2.4, -1.5});
  const WallFrame walls[] = {front};
  Renderer renderer(walls);
  const int w = 320, h = 256;
  OffscreenTarget target(w, h);
  const StickFigure fig = stick_figure(0.6, -2.5);
  auto f = frame_of(fig);
  f.target = Eigen::Vector3d(-0.5, 1.5, -1.0);
  std::vector<DrawItem> items;
  const glm::vec3 colour = character_colour(0);
  plan_fighter(f, colour, items);
  std::size_t caps = 0;  // bones fatter than their parent joint's sphere get a rounded end
  for (std::size_t j = 1; j < f.parents.size(); ++j)
    if (f.parents[j] >= 0 && f.joint_radii_m[j] > 1.08f * f.joint_radii_m[static_cast<std::size_t>(f.parents[j])]) ++caps;
  ASSERT_EQ(items.size(), 11u + 10u + caps + 1u);  // joints + bones + rounded ends + target

  const EyeView view = off_axis(front, {0.0, 1.67, 0.0}, 0.05, 100.0);
  target.bind();
  renderer.clear(0, 0, w, h);
  renderer.draw(view, items);
  std::vector<std::uint8_t> rgba;
  target.read(rgba);
  if (const char* dump = std::getenv("KUMITE_TEST_DUMP")) write_png(std::string(dump) + "/stick.png", w, h, rgba);

  // The figure's screen box (head to feet, hand to hand) with a margin for the radii.
  const Pixel head = project(view, {0.6, 1.8, -2.5}, w, h), feet = project(view, {0.6, 0.0, -2.5}, w, h);
  const Pixel lhand = project(view, {0.6 - 0.5, 1.2, -2.4}, w, h), rhand = project(view, {0.6 + 0.5, 1.2, -2.4}, w, h);
  int inside = 0, outside = 0, red = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint8_t* px = &rgba[(static_cast<std::size_t>(y) * w + x) * 4];
      if (near_colour(px, kTargetColour)) ++red;
      if (!near_colour(px, colour)) continue;
      const bool in = x >= lhand.x - 3 && x <= rhand.x + 3 && y >= head.y - 3 && y <= feet.y + 3;
      (in ? inside : outside)++;
    }
  // The figure covers a good part of its box; nothing orange strays outside it.
  const int box = (rhand.x - lhand.x) * (feet.y - head.y);
  EXPECT_GT(inside, box / 12) << "box " << box;
  EXPECT_EQ(outside, 0);
  EXPECT_GT(red, 10);  // the target sphere, 5 cm at 1.7 m
  // The figure stands right of centre (x = 0.6 m): most of it right of the image centre.
  EXPECT_GT(lhand.x, w / 2 - 20);
}

TEST(Render, EmptyRoomHasNoFighterColour) {
  HeadlessContext context;
  const WallFrame front = wall_frame({-1.5, 0, -1.5}, {1.5, 0, -1.5}, {-1.5, 2.4, -1.5});
  const WallFrame walls[] = {front};
  Renderer renderer(walls);
  OffscreenTarget target(160, 128);
  target.bind();
  renderer.clear(0, 0, 160, 128);
  renderer.draw(off_axis(front, {0.0, 1.67, 0.0}, 0.05, 100.0), {});
  std::vector<std::uint8_t> rgba;
  target.read(rgba);
  int coloured = 0, lines = 0;
  for (std::size_t i = 0; i < rgba.size(); i += 4) {
    if (near_colour(&rgba[i], character_colour(0))) ++coloured;
    if (rgba[i + 2] > 60) ++lines;  // the floor grid
  }
  EXPECT_EQ(coloured, 0);
  EXPECT_GT(lines, 100);
}

namespace {
std::vector<std::uint8_t> frame_rgba(int w, int h, std::uint8_t shade) {
  std::vector<std::uint8_t> rgba(static_cast<std::size_t>(w) * h * 4, shade);
  for (std::size_t i = 0; i < rgba.size(); i += 4) rgba[i] = static_cast<std::uint8_t>(i / 4 % 251);  // red ramp
  return rgba;
}
}  // namespace

TEST(PngWriter, WritesEveryImageWhenItMayWaitAndSaysWhatFailed) {
  const auto dir = std::filesystem::temp_directory_path() / ("kumite-pngs-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    PngWriter pngs(1, true);
    for (int i = 0; i < 4; ++i) EXPECT_TRUE(pngs.push(dir / (std::to_string(i) + ".png"), 64, 32, frame_rgba(64, 32, 90)));
    EXPECT_TRUE(pngs.push(dir / "no-such-folder" / "x.png", 64, 32, frame_rgba(64, 32, 90)));
    pngs.flush();
    EXPECT_EQ(pngs.written(), 4u);
    EXPECT_EQ(pngs.dropped(), 0u);
    const auto errors = pngs.take_errors();
    ASSERT_EQ(errors.size(), 1u);
    EXPECT_NE(errors[0].find("no-such-folder/x.png"), std::string::npos) << errors[0];
  }
  // What was written is the image: RGB, the red ramp and the shade where they were.
  const cv::Mat back = cv::imread((dir / "3.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(back.type(), CV_8UC3);
  ASSERT_EQ(back.cols, 64);
  EXPECT_EQ(back.at<cv::Vec3b>(1, 5), cv::Vec3b(90, 90, (64 + 5) % 251));  // BGR
  std::filesystem::remove_all(dir);
}

TEST(PngWriter, InRealTimeAFullQueueDropsInsteadOfWaiting) {
  const auto dir = std::filesystem::temp_directory_path() / ("kumite-pngs-rt-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  PngWriter pngs(1, false);
  // 1080p images take the writer about 0.1 s each: of ten pushed back to back (made first,
  // so pushing is only moving them), room for one waiting and one being written.
  std::vector<std::vector<std::uint8_t>> images;
  for (int i = 0; i < 10; ++i) images.push_back(frame_rgba(1920, 1080, 40));
  int accepted = 0;
  for (int i = 0; i < 10; ++i)
    accepted += pngs.push(dir / (std::to_string(i) + ".png"), 1920, 1080, std::move(images[static_cast<std::size_t>(i)]));
  EXPECT_LT(accepted, 10);
  pngs.flush();
  EXPECT_EQ(pngs.written(), static_cast<std::uint64_t>(accepted));
  EXPECT_EQ(pngs.dropped(), static_cast<std::uint64_t>(10 - accepted));
  std::filesystem::remove_all(dir);
}

TEST(Scene, EachOfSixCharactersHasItsOwnColour) {
  // As the pixel checks see colour: hue ratios (each channel over the brightest).
  auto ratios = [](glm::vec3 c) { return c / std::max({c.r, c.g, c.b}); };
  for (int i = 0; i < 6; ++i)
    for (int j = i + 1; j < 6; ++j) {
      const glm::vec3 d = glm::abs(ratios(character_colour(i)) - ratios(character_colour(j)));
      EXPECT_GT(std::max({d.r, d.g, d.b}), 0.25f) << i << " and " << j;
    }
  EXPECT_EQ(character_colour(6), character_colour(0));  // then it cycles
}

namespace {
/// Pixels (RGBA, top row first) of `rgba` (row width `w`) in the block at column x0, row y0,
/// `bw` x `bh`, compared with `ref` (bw x bh) on the channels in `mask`: how many differ.
int differing(const std::vector<std::uint8_t>& rgba, int w, int x0, int y0, const std::vector<std::uint8_t>& ref,
              int bw, int bh, std::array<bool, 3> mask) {
  int n = 0;
  for (int y = 0; y < bh; ++y)
    for (int x = 0; x < bw; ++x) {
      const std::uint8_t* a = &rgba[(static_cast<std::size_t>(y0 + y) * w + x0 + x) * 4];
      const std::uint8_t* b = &ref[(static_cast<std::size_t>(y) * bw + x) * 4];
      for (int c = 0; c < 3; ++c)
        if (mask[static_cast<std::size_t>(c)] && std::abs(a[c] - b[c]) > 2) {
          ++n;
          break;
        }
    }
  return n;
}
}  // namespace

TEST(Stereo, EachModePutsEachEyeWhereItSays) {
  HeadlessContext context;
  const WallFrame front = wall_frame({-1.5, 0, -1.5}, {1.5, 0, -1.5}, {-1.5, 2.4, -1.5});
  const WallFrame walls[] = {front};
  Renderer renderer(walls);
  std::vector<DrawItem> items;
  plan_fighter(frame_of(stick_figure(0.3, -2.5)), character_colour(0), items);
  // Eyes 0.4 m apart (exaggerated), the figure 1 m behind the wall: the two images differ.
  const std::array<EyeView, 2> views = {off_axis(front, {-0.2, 1.67, 0.0}, 0.05, 100.0),
                                        off_axis(front, {0.2, 1.67, 0.0}, 0.05, 100.0)};
  const int w = 160, h = 128;
  auto render = [&](StereoMode mode, int tw, int th) {
    OffscreenTarget target(tw, th);
    target.bind();
    draw_wall_stereo(renderer, mode, {0, 0, tw, th}, views, items);
    std::vector<std::uint8_t> rgba;
    target.read(rgba);
    return rgba;
  };
  // Each eye alone, at the size each mode gives it.
  auto alone = [&](int e, int tw, int th) {
    OffscreenTarget target(tw, th);
    target.bind();
    renderer.clear(0, 0, tw, th);
    renderer.draw(views[static_cast<std::size_t>(e)], items);
    std::vector<std::uint8_t> rgba;
    target.read(rgba);
    return rgba;
  };
  const auto left = alone(0, w, h), right = alone(1, w, h);
  constexpr std::array<bool, 3> rgb{true, true, true};
  ASSERT_GT(differing(left, w, 0, 0, right, w, h, rgb), 100) << "the eyes must see different images for this test";

  EXPECT_EQ(differing(render(StereoMode::mono, w, h), w, 0, 0, left, w, h, rgb), 0);
  const auto sbs = render(StereoMode::side_by_side, 2 * w, h);  // left eye on the left half
  EXPECT_EQ(differing(sbs, 2 * w, 0, 0, left, w, h, rgb), 0);
  EXPECT_EQ(differing(sbs, 2 * w, w, 0, right, w, h, rgb), 0);
  const auto tb = render(StereoMode::top_bottom, w, 2 * h);  // left eye on top (rows come top first)
  EXPECT_EQ(differing(tb, w, 0, 0, left, w, h, rgb), 0);
  EXPECT_EQ(differing(tb, w, 0, h, right, w, h, rgb), 0);
  const auto ana = render(StereoMode::anaglyph, w, h);  // red from the left eye, green and blue from the right
  EXPECT_EQ(differing(ana, w, 0, 0, left, w, h, {true, false, false}), 0);
  EXPECT_EQ(differing(ana, w, 0, 0, right, w, h, {false, true, true}), 0);
  EXPECT_GT(differing(ana, w, 0, 0, left, w, h, rgb), 100) << "and not simply the left eye";
}
