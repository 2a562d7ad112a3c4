// The demo installation headless, with the real fighter: the shipped motions are built into
// a database here (as set-up does), the shipped characters are loaded, a script of orders is
// played, and the run's PNGs and frames.jsonl are checked: the fighter's colour where its
// root projects, the character switch in colour, every scripted order logged once with its
// outcome, strikes ending in hit or miss. Tracking: none (the head stays at the default),
// so the test stays short; the tracker's recorded path is exercised by kumite itself.
#include <gtest/gtest.h>

#include <fstream>
#include <iostream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include "kumite/app/config.hpp"
#include "kumite/app/export.hpp"
#include "kumite/app/frame_log.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/run.hpp"
#include "kumite/app/scene.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/database.hpp"

using namespace kumite::app;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = KUMITE_SOURCE_DIR;

/// Builds the shipped motions into a database once per test binary (a few seconds).
fs::path demo_database() {
  static const fs::path path = [] {
    const fs::path dir = fs::temp_directory_path() / ("kumite_app_test_db_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const auto set = kumite::content::read_annotations(kSource / "content/motions/motions.toml");
    const auto clips = kumite::content::load_annotated_clips(set);
    const auto sources = kumite::content::segment_sources(set, clips);
    const auto db = kumite::content::build_database(sources, {});
    kumite::content::save_database(db, dir / "fighter.kdb");
    return dir / "fighter.kdb";
  }();
  return path;
}

struct Image {
  int w = 0, h = 0;
  std::vector<unsigned char> rgb;
  const unsigned char* at(int x, int y) const { return &rgb[(static_cast<std::size_t>(y) * w + x) * 3]; }
};

Image load_png(const fs::path& p) {
  Image img;
  int n = 0;
  unsigned char* data = stbi_load(p.c_str(), &img.w, &img.h, &n, 3);
  if (!data) return img;
  img.rgb.assign(data, data + static_cast<std::size_t>(img.w) * img.h * 3);
  stbi_image_free(data);
  return img;
}

bool near_colour(const unsigned char* px, glm::vec3 base) {
  const float r = px[0], g = px[1], b = px[2];
  const float m = std::max({r, g, b});
  if (m < 40) return false;
  const float bm = std::max({base.r, base.g, base.b});
  return std::abs(r / m - base.r / bm) < 0.12f && std::abs(g / m - base.g / bm) < 0.12f &&
         std::abs(b / m - base.b / bm) < 0.12f;
}

glm::dmat4 matrix(const nlohmann::json& a) {
  glm::dmat4 m;
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) m[c][r] = a[static_cast<std::size_t>(c * 4 + r)].get<double>();
  return m;
}

/// Pixel (top-left origin) of a room point in a wall image, from the logged matrices.
glm::ivec2 project(const nlohmann::json& wall_eye, const glm::dvec3& p, int w, int h) {
  const glm::dvec4 c = matrix(wall_eye["projection"]) * matrix(wall_eye["view"]) * glm::dvec4(p, 1);
  return {static_cast<int>((c.x / c.w + 1) / 2 * w), static_cast<int>((1 - c.y / c.w) / 2 * h)};
}

/// Pixels of `colour` in the box around the fighter standing at `root` (1.9 m tall, 1.2 m wide).
std::pair<int, int> count_fighter_pixels(const Image& img, const nlohmann::json& wall_eye,
                                         const glm::dvec3& root, glm::vec3 colour) {
  const auto top = project(wall_eye, root + glm::dvec3(0, 2.0, 0), img.w, img.h);
  const auto foot = project(wall_eye, root, img.w, img.h);
  const auto left = project(wall_eye, root + glm::dvec3(-0.7, 1, 0), img.w, img.h);
  const auto right = project(wall_eye, root + glm::dvec3(0.7, 1, 0), img.w, img.h);
  int inside = 0, outside = 0;
  for (int y = 0; y < img.h; ++y)
    for (int x = 0; x < img.w; ++x) {
      if (!near_colour(img.at(x, y), colour)) continue;
      const bool in = x >= left.x && x <= right.x && y >= top.y && y <= foot.y + 2;
      (in ? inside : outside)++;
    }
  return {inside, outside};
}

}  // namespace

TEST(Demo, HeadlessRunShowsTheFighterAndLogsTheOrders) {
  auto cfg = load_installation_config(kSource / "config/demo.toml");
  // The checks read the capsules' colours: the technician's view, in the void (the skinned
  // body in the hall: tests/app/test_body_render.cpp).
  cfg.render.fighter = FighterLook::capsules;
  cfg.render.hall = false;
  cfg.fighter.database = demo_database();
  cfg.tracking.source = TrackingSource::none;
  const fs::path out = fs::temp_directory_path() / ("kumite_app_test_demo_" + std::to_string(::getpid()));
  fs::remove_all(out);
  fs::create_directories(out);
  const fs::path script = out / "orders.csv";
  std::ofstream(script) << "time_s,order\n0.3,punch_right\n0.45,kick_left\n1.5,character 9\n"
                           "1.6,character 2\n1.9,kick_right\n";
  InstallationOptions io;
  io.orders_script = script;
  Installation inst(cfg, make_fixed_head_input("test"), io);
  ASSERT_TRUE(inst.console().problems.empty() || inst.character_count() == 5);
  ASSERT_EQ(inst.character_count(), 5);
  HeadlessOptions ho;
  ho.frames = 180;  // 3 s at 60 Hz
  ho.out = out;
  ho.save_every = 30;
  ho.resolution = std::array<int, 2>{320, 180};
  ho.real_time = false;
  ASSERT_EQ(run_headless(inst, ho), 0);

  std::vector<nlohmann::json> frames;
  std::ifstream in(out / "frames.jsonl");
  for (std::string line; std::getline(in, line);) frames.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(frames.size(), 180u);

  // Every scripted order appears once, with an outcome.
  std::map<std::string, std::vector<nlohmann::json>> by_order;
  int hits_or_misses = 0;
  std::string striking;  // the accepted strike order whose outcome is due
  for (const auto& f : frames)
    for (const auto& e : f["events"]) {
      if (e.contains("order")) by_order[e["order"].get<std::string>()].push_back(e);
      if (e["type"] == "order" && e["order"].get<std::string>().rfind("character", 0) != 0) striking = e["order"];
      if (e["type"] == "hit" || e["type"] == "dodged" || e["type"] == "miss") {
        ++hits_or_misses;
        // Each outcome names its strike's order, on the console too.
        EXPECT_EQ(e.value("order", ""), striking) << e.dump();
        EXPECT_EQ(f["console"]["last_order"], striking) << f["console"].dump();
        EXPECT_EQ(f["console"]["last_outcome"].get<std::string>().rfind(e["type"].get<std::string>(), 0), 0u);
        striking.clear();
        // The moment of contact is saved whatever --save-every says (frame 30k is anyway).
        const int frame = f["frame"].get<int>();
        for (const char* name : {"front_left", "front_right", "floor_left", "floor_right"})
          EXPECT_TRUE(fs::exists(out / fmt::format("{}_{:05}.png", name, frame))) << name << " at contact, frame " << frame;
      }
    }
  int saved = 0;
  for (const auto& entry : fs::directory_iterator(out)) saved += entry.path().extension() == ".png";
  EXPECT_LE(saved, 8 * (6 + hits_or_misses)) << "PNGs only every 30th frame and at contacts";
  for (const char* o : {"punch_right", "kick_left", "character 9", "character 2", "kick_right"})
    EXPECT_FALSE(by_order[o].empty()) << o << " missing from frames.jsonl";
  ASSERT_FALSE(by_order["punch_right"].empty());
  EXPECT_EQ(by_order["punch_right"][0]["type"], "order");
  ASSERT_FALSE(by_order["kick_left"].empty());
  EXPECT_EQ(by_order["kick_left"][0]["type"], "order_ignored");  // mid-strike
  ASSERT_FALSE(by_order["character 9"].empty());
  EXPECT_EQ(by_order["character 9"][0]["type"], "order_ignored");
  EXPECT_NE(by_order["character 9"][0]["text"].get<std::string>().find("does not exist"), std::string::npos);
  EXPECT_GE(hits_or_misses, 2) << "the punch and the kick each end in hit or miss";
  EXPECT_EQ(frames.back()["fighter"]["character"], 2);

  // The fighter is drawn where it stands: in Kenji's colour at first, Mei's after the switch.
  // Frame 90: the punch is over (contact at 1.12 s since strikes play at their playback rate;
  // at frame 60 the fist is reaching for the visitor's eyes, i.e. the front wall's camera, and
  // fills the picture outside the standing box).
  for (int frame : {90, 150}) {
    const auto& f = frames[static_cast<std::size_t>(frame)];
    ASSERT_TRUE(f["fighter"]["present"].get<bool>());
    const auto r = f["fighter"]["root"];
    const glm::dvec3 root(r[0].get<double>(), r[1].get<double>(), r[2].get<double>());
    const int character = f["fighter"]["character"].get<int>() - 1;
    EXPECT_EQ(character, frame < 96 ? 0 : 1);
    for (const char* eye : {"left", "right"}) {
      const Image img = load_png(out / fmt::format("front_{}_{:05}.png", eye, frame));
      ASSERT_EQ(img.w, 320);
      const auto [inside, outside] = count_fighter_pixels(img, f["walls"]["front"][eye], root,
                                                          character_colour(character));
      EXPECT_GT(inside, 150) << "frame " << frame << " " << eye;
      EXPECT_LT(outside, inside / 20) << "frame " << frame << " " << eye;
      // The other character's colour is absent.
      const auto [other, unused] = count_fighter_pixels(img, f["walls"]["front"][eye], root,
                                                        character_colour(1 - character));
      EXPECT_LT(other, inside / 20);
    }
  }
  fs::remove_all(out);
}

TEST(Demo, AMissingCharacterFileLeavesTheOthersAndKeepsTheKeyNumbers) {
  auto cfg = load_installation_config(kSource / "config/demo.toml");
  cfg.fighter.database = demo_database();
  cfg.tracking.source = TrackingSource::none;
  cfg.characters[0].bvh = "/nonexistent/kenji.bvh";  // character 1 (the initial one) is missing
  const fs::path dir = fs::temp_directory_path() / ("kumite_app_test_chars_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path script = dir / "orders.csv";
  std::ofstream(script) << "time_s,order\n0.1,character 1\n0.2,character 3\n";
  InstallationOptions io;
  io.orders_script = script;
  Installation inst(cfg, make_fixed_head_input("test"), io);
  EXPECT_EQ(inst.character_count(), 5);
  EXPECT_EQ(inst.character_name(2), "Bruno");
  std::vector<FrameEvent> events;
  for (int i = 0; i <= 30; ++i) {
    const auto& f = inst.step(1000.0 + i / 60.0);
    events.insert(events.end(), f.events.begin(), f.events.end());
  }
  ASSERT_TRUE(inst.frame().fighter.present) << "the other four characters still make a fighter";
  EXPECT_EQ(inst.frame().fighter.character, 2) << "character 3 (Bruno), in the config's numbering";
  bool said_missing = false;
  for (const auto& p : inst.console().problems) said_missing |= p.find("kenji.bvh does not exist") != std::string::npos;
  EXPECT_TRUE(said_missing);
  bool ignored_1 = false, changed_3 = false;
  for (const auto& e : events) {
    const std::string order = e.order ? kumite::to_string(*e.order) : "";
    if (e.type == EventType::order_ignored && order == "character 1")
      ignored_1 = inst.event_text(e).find("not loaded") != std::string::npos;
    if (e.type == EventType::character_changed)
      changed_3 = inst.event_text(e) == "character 3 (Bruno)" && order == "character 3";
  }
  EXPECT_TRUE(ignored_1);
  EXPECT_TRUE(changed_3);
  fs::remove_all(dir);
}

// Issue 13: the fighter in FrameData is plain copyable data (no spans into the fighter),
// filled without allocating after warm-up, and the log carries its joints by name.
TEST(Demo, TheFighterIsPlainDataInTheFrameAndInTheLog) {
  auto cfg = load_installation_config(kSource / "config/demo.toml");
  cfg.fighter.database = demo_database();
  cfg.tracking.source = TrackingSource::none;
  const fs::path out = fs::temp_directory_path() / ("kumite_app_test_pose_" + std::to_string(::getpid()));
  fs::remove_all(out);
  fs::create_directories(out);
  const fs::path script = out / "orders.csv";
  std::ofstream(script) << "time_s,order\n0.2,punch_right\n1.2,character 2\n1.6,kick_right\n";
  InstallationOptions io;
  io.orders_script = script;
  Installation inst(cfg, make_fixed_head_input("test"), io);
  std::vector<FrameData> copies;  // FrameData copies whole: nothing points into the fighter
  const glm::dvec3* joints_at = nullptr;
  int moved = 0;
  for (int i = 0; i < 150; ++i) {
    const FrameData& f = inst.step(1000.0 + i / 60.0);
    const FighterPose& p = f.fighter;
    ASSERT_TRUE(p.present);
    ASSERT_TRUE(p.skeleton);
    ASSERT_EQ(p.joints.size(), p.skeleton->joint_names.size());
    ASSERT_EQ(p.local_rotations.size(), p.joints.size());
    ASSERT_EQ(p.skeleton->character, p.character);
    if (i > 0 && p.joints.data() != joints_at) ++moved;
    joints_at = p.joints.data();
    copies.push_back(f);
  }
  // The joints' storage moved at most once: at the switch to a character with more joints.
  EXPECT_LE(moved, 1);
  EXPECT_EQ(copies[30].fighter.character, 0);
  EXPECT_EQ(copies[140].fighter.character, 1);
  EXPECT_NE(copies[30].fighter.skeleton, copies[140].fighter.skeleton);
  // The copies kept their own joints: a strike moved them between frames 20 and 40.
  double moved_m = 0;
  for (std::size_t j = 0; j < copies[20].fighter.joints.size(); ++j)
    moved_m = std::max(moved_m, glm::length(copies[40].fighter.joints[j] - copies[20].fighter.joints[j]));
  EXPECT_GT(moved_m, 0.05);

  // The log line: joints keyed by joint name, as in FrameData (rounded to 1e-5 m).
  const auto line = nlohmann::json::parse(frame_json(copies[40], inst.console(), {}, true));
  const auto& fj = line["fighter"];
  ASSERT_TRUE(fj.contains("joints"));
  const auto& names = copies[40].fighter.skeleton->joint_names;
  ASSERT_EQ(fj["joints"].size(), names.size());
  ASSERT_EQ(fj["local_rotations"].size(), names.size());
  for (std::size_t j = 0; j < names.size(); ++j) {
    const auto& a = fj["joints"][names[j]];
    const glm::dvec3 logged(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
    EXPECT_LT(glm::length(logged - copies[40].fighter.joints[j]), 1e-5) << names[j];
  }
  fs::remove_all(out);
}

namespace {
/// A fresh `out` folder, an orders script of `orders` (CSV rows after the header) and `frames`
/// headless frames of `cfg` in simulated time, no PNGs, logged to out/frames.jsonl.
void run_ordered_demo(const InstallationConfig& cfg, const fs::path& out, const std::string& orders, int frames) {
  fs::remove_all(out);
  fs::create_directories(out);
  const fs::path script = out / "orders.csv";
  std::ofstream(script) << "time_s,order\n" << orders;
  InstallationOptions io;
  io.orders_script = script;
  Installation inst(cfg, make_fixed_head_input("test"), io);
  HeadlessOptions ho;
  ho.frames = frames;
  ho.out = out;
  ho.save_every = 0;
  ho.resolution = std::array<int, 2>{64, 36};
  ho.real_time = false;
  ASSERT_EQ(run_headless(inst, ho), 0);
}
}  // namespace

// Issue 13: a run judged from its log alone. A short headless run with a strike, exported
// from frames.jsonl as BVH on the character's skeleton, re-read with content::read_bvh:
// its forward kinematics gives the logged joints (the pose as drawn) within 1 mm.
TEST(Demo, ExportFromTheLogReproducesTheLoggedJoints) {
  auto cfg = load_installation_config(kSource / "config/demo.toml");
  cfg.fighter.database = demo_database();
  cfg.tracking.source = TrackingSource::none;
  const fs::path out = fs::temp_directory_path() / ("kumite_app_test_export_" + std::to_string(::getpid()));
  ASSERT_NO_FATAL_FAILURE(run_ordered_demo(cfg, out, "0.2,punch_right\n1.0,kick_left\n", 120));

  ExportOptions eo;
  eo.log = out / "frames.jsonl";
  eo.from_s = 0.095;  // between frames: time_s is a sum of steps, not exact
  eo.to_s = 1.905;
  eo.bvh = out / "fighter.bvh";
  eo.head_csv = out / "head.csv";
  const ExportReport rep = export_log(cfg, eo);
  EXPECT_EQ(rep.character, 0);
  EXPECT_EQ(rep.first_frame, 6);
  EXPECT_EQ(rep.last_frame, 114);
  EXPECT_EQ(rep.frames, 109);
  EXPECT_NEAR(rep.frame_time_s, 1.0 / 60, 1e-9);

  const kumite::content::Clip clip = kumite::content::read_bvh(out / "fighter.bvh");
  ASSERT_EQ(clip.frame_count, rep.frames);
  EXPECT_NEAR(clip.frame_time_s, 1.0 / 60, 1e-6);
  std::vector<nlohmann::json> frames;
  std::ifstream in(out / "frames.jsonl");
  for (std::string line; std::getline(in, line);) frames.push_back(nlohmann::json::parse(line));
  const auto n = static_cast<std::size_t>(clip.skeleton.joint_count());
  std::vector<Eigen::Vector3d> pos(n);
  std::vector<Eigen::Quaterniond> rot(n);
  double worst_m = 0, travel_m = 0;
  bool striking = false;
  for (int k = 0; k < clip.frame_count; ++k) {
    const auto& f = frames[static_cast<std::size_t>(rep.first_frame + k)];
    striking |= f["fighter"]["state"] == "striking";
    kumite::content::forward_kinematics(clip, k, pos, rot);
    for (std::size_t j = 0; j < n; ++j) {
      const auto& a = f["fighter"]["joints"][clip.skeleton.names[j]];
      const Eigen::Vector3d logged(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
      worst_m = std::max(worst_m, (pos[j] - logged).norm());
      if (k > 0) {
        const auto& b = frames[static_cast<std::size_t>(rep.first_frame)]["fighter"]["joints"][clip.skeleton.names[j]];
        travel_m = std::max(travel_m, (logged - Eigen::Vector3d(b[0].get<double>(), b[1].get<double>(), b[2].get<double>())).norm());
      }
    }
  }
  EXPECT_TRUE(striking) << "the interval holds a strike";
  EXPECT_GT(travel_m, 0.2) << "the fighter moved (a strike)";
  EXPECT_LT(worst_m, 1e-3) << "m, BVH joints vs the logged joints";
  std::cout << "export: worst joint difference " << worst_m * 1e3 << " mm over " << clip.frame_count << " frames\n";

  // The head as CSV: one row per frame of the interval.
  std::ifstream csv(out / "head.csv");
  int rows = 0;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, rep.frames + 1);

  // A log cut short mid-line (a run killed while writing) exports what is complete.
  {
    std::ifstream whole(out / "frames.jsonl");
    std::string all((std::istreambuf_iterator<char>(whole)), std::istreambuf_iterator<char>());
    std::ofstream(out / "cut.jsonl") << all.substr(0, all.size() - 100);
  }
  eo.log = out / "cut.jsonl";
  eo.to_s = 1e9;
  const ExportReport cut = export_log(cfg, eo);
  EXPECT_TRUE(cut.truncated_last_line);
  EXPECT_EQ(cut.last_frame, 118);
  // An interval with no frames is an error.
  eo.log = out / "frames.jsonl";
  eo.from_s = 50;
  eo.to_s = 60;
  EXPECT_THROW(export_log(cfg, eo), kumite::Error);
  // A bad number names file, line and key.
  {
    std::ifstream whole(out / "frames.jsonl");
    std::string first;
    std::getline(whole, first);
    const auto at = first.find("\"time_s\":");
    ASSERT_NE(at, std::string::npos);
    std::ofstream(out / "bad.jsonl") << first.substr(0, at) << "\"time_s\":\"soon\"," << first.substr(first.find(',', at) + 1) << "\n";
  }
  eo.log = out / "bad.jsonl";
  eo.from_s = 0;
  try {
    export_log(cfg, eo);
    ADD_FAILURE() << "a bad time_s was taken";
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.jsonl:1: time_s: not a number"), std::string::npos) << e.what();
  }
  fs::remove_all(out);
}

// An interval with a character switch: one BVH per character run beside --out (each on its
// character's skeleton), none at --out itself. Read back with content::read_bvh, each run's
// frames are its own in the log, and its forward kinematics gives the logged joints within 1 mm
// wherever the switch's easing is over (the logged joints ease from the old body's for a while;
// the rotations are the new character's from its first frame).
TEST(Demo, ExportOfAnIntervalWithACharacterSwitchWritesOneBvhPerCharacter) {
  auto cfg = load_installation_config(kSource / "config/demo.toml");
  cfg.fighter.database = demo_database();
  cfg.tracking.source = TrackingSource::none;
  ASSERT_GE(cfg.characters.size(), 2u);
  const fs::path out = fs::temp_directory_path() / ("kumite_app_test_export_switch_" + std::to_string(::getpid()));
  ASSERT_NO_FATAL_FAILURE(run_ordered_demo(cfg, out, "0.2,punch_right\n1.0,character 2\n", 150));

  ExportOptions eo;
  eo.log = out / "frames.jsonl";
  eo.bvh = out / "fighter.bvh";
  const ExportReport rep = export_log(cfg, eo);
  ASSERT_EQ(rep.runs.size(), 2u);
  EXPECT_FALSE(fs::exists(out / "fighter.bvh")) << "--out itself is not written when the interval has runs";
  EXPECT_EQ(rep.runs[0].character, 0);
  EXPECT_EQ(rep.runs[1].character, 1);
  EXPECT_EQ(rep.runs[0].bvh, out / ("fighter.01-" + cfg.characters[0].name + ".bvh"));
  EXPECT_EQ(rep.runs[1].bvh, out / ("fighter.02-" + cfg.characters[1].name + ".bvh"));
  EXPECT_EQ(rep.runs[0].frames + rep.runs[1].frames, rep.frames);
  EXPECT_EQ(rep.runs[0].last_frame + 1, rep.runs[1].first_frame);
  EXPECT_EQ(rep.character, 0);

  std::vector<nlohmann::json> frames;
  std::ifstream in(out / "frames.jsonl");
  for (std::string line; std::getline(in, line);) frames.push_back(nlohmann::json::parse(line));
  for (std::size_t r = 0; r < rep.runs.size(); ++r) {
    const ExportRun& run = rep.runs[r];
    const kumite::content::Clip clip = kumite::content::read_bvh(run.bvh);
    ASSERT_EQ(clip.frame_count, run.frames);
    EXPECT_NEAR(clip.frame_time_s, 1.0 / 60, 1e-6);
    const kumite::content::Clip own = kumite::content::read_bvh(cfg.resolve(cfg.characters[static_cast<std::size_t>(run.character)].bvh));
    EXPECT_EQ(clip.skeleton.names, own.skeleton.names) << "run " << r << " is on its character's skeleton";
    const auto n = static_cast<std::size_t>(clip.skeleton.joint_count());
    std::vector<Eigen::Vector3d> pos(n);
    std::vector<Eigen::Quaterniond> rot(n);
    int matched = 0;
    double worst_m = 0;
    for (int k = 0; k < clip.frame_count; ++k) {
      const auto& f = frames[static_cast<std::size_t>(run.first_frame + k)];
      ASSERT_EQ(f["fighter"]["character"].get<int>(), run.character + 1);
      kumite::content::forward_kinematics(clip, k, pos, rot);
      double frame_worst = 0;
      for (std::size_t j = 0; j < n; ++j) {
        const auto& a = f["fighter"]["joints"][clip.skeleton.names[j]];
        frame_worst = std::max(frame_worst, (pos[j] - Eigen::Vector3d(a[0].get<double>(), a[1].get<double>(), a[2].get<double>())).norm());
      }
      // (the second run's last 30 frames: 0.5 s after the switch's easing began)
      if (r == 0 || k >= clip.frame_count - 30) {
        worst_m = std::max(worst_m, frame_worst);
        ++matched;
      }
    }
    EXPECT_GE(matched, 30);
    EXPECT_LT(worst_m, 1e-3) << "m, run " << r << ": BVH joints vs the logged joints";
    std::cout << "export run " << r + 1 << " (" << run.character_name << "): " << clip.frame_count << " frames, worst joint "
              << worst_m * 1e3 << " mm over " << matched << "\n";
  }
  fs::remove_all(out);
}
