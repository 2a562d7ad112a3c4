// kumite-motion: the offline motion-content tool. One function per sub-command:
//   annotate <clips...> --out motions.toml   propose annotations for people to review
//   make-characters [--catalog characters.toml] [--base 135_08.bvh] [--check]
//                                            generate the shipped character skeletons
//   build --annotations motions.toml --out fighter.kdb
//                                            the fighter's motion database
//   resample clip.bvh --fps 30 --out clip30.bvh
//                                            a clip at another frame rate (slerp / lerp)
//   strike --db fighter.kdb --character <name|file.bvh> --order punch_right --target X,Y,Z
//          --out strike.bvh --report strike.json
//                                            one adapted strike, written as BVH + JSON report
//   bench [--db fighter.kdb]                 retrieval and adaptation timings as JSON (+ motion quality)
//   quality --db fighter.kdb --out quality.json [--characters a,b] [--targets 12] [--bvh-dir DIR]
//                                            what the eye sees: the strike grid, each strike's
//                                            BVH read back, figures beside the source clip's
//   bout --db fighter.kdb --out bout.bvh --report bout.json [--seconds 20]
//                                            a scripted bout with a SYNTHETIC visitor, one BVH
//                                            per character run, figures over the whole bout
// Errors: one line on stderr, exit 1.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <cstdio>
#include <random>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/behaviour.hpp"
#include "kumite/content/database.hpp"
#include "kumite/content/bvh.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/character.hpp"
#include "kumite/content/fighter.hpp"
#include "kumite/content/motion_quality.hpp"
#include "kumite/content/planner.hpp"
#include "kumite/content/proportions.hpp"

namespace fs = std::filesystem;
using namespace kumite::content;

namespace {

/// The fighter's settings every command that plays the fighter uses: defaults, or the
/// [fighter.behaviour] / [fighter.behaviour.feet] / [fighter.retrieval] tables of the
/// installation file given with --tunables (the same keys and checks as `kumite --config`).
FighterConfig g_fighter;

// ---- annotate ------------------------------------------------------------------------------

struct AnnotateArgs {
  std::vector<std::string> clips;
  std::string out;
  bool no_mirror = false;
};

void add_annotate(CLI::App& app, AnnotateArgs& a) {
  auto* cmd = app.add_subcommand("annotate", "Propose motions.toml annotations (strikes, rest, walk) from BVH clips");
  cmd->add_option("clips", a.clips, "BVH clips")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", a.out, "motions.toml to write (an existing one is kept as a .bak)")->required();
  cmd->add_flag("--no-mirror", a.no_mirror, "mark the clips mirror = false");
}

int run_annotate(const AnnotateArgs& a) {
  AnnotationSet set;
  const fs::path out = fs::absolute(a.out);
  set.source = out;
  for (const auto& file : a.clips) {
    Clip clip = read_bvh(file);
    if (clip.skeleton.dialect.empty()) map_canonical(clip.skeleton, file);
    if (const BvhUnitCheck u = check_bvh_unit(clip, file); !u.warning.empty()) {
      fmt::print(stderr, "kumite-motion: warning: {}\n", u.warning);
    }
    if (const std::string w = structural_mapping_warning(clip.skeleton, file); !w.empty())
      fmt::print(stderr, "kumite-motion: warning: {}\n", w);
    std::string rel = fs::relative(fs::absolute(file), out.parent_path()).generic_string();
    ClipAnnotation c = propose_annotations(clip, rel);
    c.mirror = !a.no_mirror;
    fmt::print("{}: {} frames @ {:.0f} fps, dialect {}:\n", file, clip.frame_count, clip.frame_rate_hz(),
               clip.skeleton.dialect);
    for (const auto& m : c.motions) {
      fmt::print("  {:<28} {:<6} [{:5}, {:5}]", m.name, to_string(m.semantics), m.first_frame, m.last_frame);
      if (m.hit_frame) {
        fmt::print("  {} hit f{} ({:.2f} s), peak {:.1f} m/s, extension {:.2f}, {}", to_string(*m.hit_segment),
                   *m.hit_frame, *m.hit_frame * clip.frame_time_s, m.peak_speed_mps, m.extension,
                   m.height ? to_string(*m.height) : "?");
        if (!m.note.empty()) fmt::print("  ({})", m.note);
      }
      fmt::print("\n");
    }
    set.clips.push_back(std::move(c));
  }
  const fs::path backup = kumite::keep_previous_version(out);
  write_annotations(out, set);
  fmt::print("wrote {}{}; review it before building the database\n", out.string(),
             backup.empty() ? "" : fmt::format(" (previous kept as {})", backup.string()));
  return 0;
}

// ---- make-characters -----------------------------------------------------------------------

struct MakeCharactersArgs {
  std::string catalog = (default_content_dir() / "characters" / "characters.toml").string();
  std::string base = (default_content_dir() / "motions" / "135_08.bvh").string();
  bool check = false;
};

void add_make_characters(CLI::App& app, MakeCharactersArgs& a) {
  auto* cmd = app.add_subcommand("make-characters",
                                 "Generate each character BVH of characters.toml from its [character.generate] "
                                 "spec (per-segment scales of the base skeleton, then its stature)");
  cmd->add_option("--catalog", a.catalog, "characters.toml")->capture_default_str()->check(CLI::ExistingFile);
  cmd->add_option("--base", a.base, "base skeleton BVH")->capture_default_str()->check(CLI::ExistingFile);
  cmd->add_flag("--check", a.check, "write nothing; exit 1 when a file differs from what would be generated");
}

int run_make_characters(const MakeCharactersArgs& a) {
  const CharacterCatalog catalog = read_characters(a.catalog);
  const Clip base = read_bvh(a.base);
  int differing = 0;
  fmt::print("{:<10} {:>9} {:>10} {:>7} {:>7} {:>7} {:>9} {:>13}  {}\n", "name", "stature_m", "standing_m", "arm/h",
             "leg/h", "torso/h", "shoulder", "dialect", "file");
  for (const auto& e : catalog.characters) {
    if (!e.generate) continue;
    const Clip c = make_character(base.skeleton, *e.generate, e.name);
    const Proportions p = measure_proportions(c.skeleton);
    const fs::path path = catalog.resolve(e);
    const std::string text = format_bvh(c);
    fmt::print("{:<10} {:>9.3f} {:>10.3f} {:>7.3f} {:>7.3f} {:>7.3f} {:>8.3f}m {:>13}  {}\n", e.name, p.stature_m,
               p.standing_height_m, p.arm_ratio(),
               p.leg_ratio(), p.torso_ratio(), p.shoulder_width_m, c.skeleton.dialect, path.string());
    if (a.check) {
      std::ifstream in(path, std::ios::binary);
      std::ostringstream current;
      current << in.rdbuf();
      const std::string old = current.str();
      if (old != text) {
        fmt::print(stderr, "kumite-motion: {}: differs from the generated skeleton\n", path.string());
        ++differing;
      }
    } else {
      write_bvh(path, c);
    }
  }
  return differing == 0 ? 0 : 1;
}


// ---- shared helpers ------------------------------------------------------------------------

/// The folder an output file goes to exists (made if missing) before any work starts, or the
/// run is refused at once with one line (not after minutes of work).
void prepare_output(const std::string& option, const std::string& path) {
  const fs::path parent = fs::absolute(path).parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent))
    throw kumite::Error("output", "folder", fmt::format("{} {}: cannot create the folder {}{}", option, path, parent.string(),
                                                        ec ? ": " + ec.message() : ""));
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::clamp(p / 100.0 * static_cast<double>(v.size() - 1), 0.0,
                                                      static_cast<double>(v.size() - 1)));
  return v[i];
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}
nlohmann::json stats_json(const std::vector<double>& us) {
  return {{"n", us.size()}, {"mean", mean(us)}, {"p50", percentile(us, 50)}, {"p99", percentile(us, 99)},
          {"p99_9", percentile(us, 99.9)}, {"max", percentile(us, 100)}};
}

// What this machine adds to a timed update: a fixed workload of about the adaptation's median
// time, timed the same way (steady_clock around it) as often as the strikes' frames. Its p50 is
// the work; what lies above it is the machine's (interrupts, a hypervisor), not the code's.
nlohmann::json machine_noise_json(const std::vector<double>& adapt_us) {
  if (adapt_us.empty()) return nullptr;
  std::vector<double> sorted = adapt_us;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double want_us = sorted[sorted.size() / 2];
  volatile double x = 1;
  const auto work = [&](int n) {
    for (int k = 0; k < n; ++k) x = std::sin(x) + 1.0001;
  };
  // Calibrate: iterations that take want_us (the least of a few tries).
  int n = 1000;
  double best = 1e9;
  for (int i = 0; i < 50; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    work(n);
    best = std::min(best, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  n = std::max(1, static_cast<int>(n * want_us / std::max(1e-3, best)));
  std::vector<double> us;
  us.reserve(adapt_us.size());
  for (std::size_t i = 0; i < adapt_us.size(); ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    work(n);
    us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  nlohmann::json j = stats_json(us);
  std::sort(us.begin(), us.end());
  const double p50 = us[us.size() / 2];
  j["over_p50_plus_15us_pct"] =
      100.0 * static_cast<double>(us.end() - std::upper_bound(us.begin(), us.end(), p50 + 15)) / static_cast<double>(us.size());
  j["what"] = "a fixed workload of the adaptation's median time, timed as often as its frames: above p50 is the machine";
  return j;
}
double now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
Database build_from_annotations(const std::string& annotations, bool verbose) {
  const AnnotationSet set = read_annotations(annotations);
  if (verbose) fmt::print(stderr, "reading {} clips of {}\n", set.clips.size(), annotations);
  const std::vector<Clip> clips = load_annotated_clips(set);
  BuildOptions options;
  if (verbose) {
    options.progress = [](std::string_view what, double fraction) {
      fmt::print(stderr, "  [{:3.0f}%] {}\n", fraction * 100, what);
    };
  }
  return build_database(segment_sources(set, clips), options);
}

// ---- build ---------------------------------------------------------------------------------

struct BuildArgs {
  std::string annotations;
  std::string out;
};

void add_build(CLI::App& app, BuildArgs& a) {
  auto* cmd = app.add_subcommand("build", "Build the fighter's motion database (.kdb) from motions.toml");
  cmd->add_option("--annotations", a.annotations, "motions.toml")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", a.out, "database file to write (atomically)")->required();
}

int run_build(const BuildArgs& a) {
  const double t0 = now_s();
  const Database db = build_from_annotations(a.annotations, true);
  save_database(db, a.out);
  int strikes = 0, rest = 0, walks = 0, blocks = 0;
  for (const auto& s : db.segments) {
    strikes += s.kind == SegmentKind::strike;
    rest += s.kind == SegmentKind::rest;
    walks += s.kind == SegmentKind::walk;
    blocks += s.kind == SegmentKind::block;
  }
  fmt::print("wrote {}: {} segments ({} strikes, {} blocks, {} rest, {} walk, mirrored copies included), {} strike "
             "candidates in {} clusters, {} block candidates; actor {} (leg length {:.3f} m); {:.1f} s\n",
             a.out, db.segments.size(), strikes, blocks, rest, walks, db.index.size, db.index.clusters.size(),
             db.block_index.size, db.actor_name, db.actor.leg_length_m, now_s() - t0);
  return 0;
}

// ---- resample ------------------------------------------------------------------------------

struct ResampleArgs {
  std::string in, out;
  double fps = 0;
};

void add_resample(CLI::App& app, ResampleArgs& a) {
  auto* cmd = app.add_subcommand(
      "resample", "Write a BVH clip at another frame rate (rotations slerped, positions lerped; same skeleton and unit)");
  cmd->add_option("in", a.in, "clip.bvh")->required()->check(CLI::ExistingFile);
  cmd->add_option("--fps", a.fps, "frames per second of the output (e.g. 30, 60)")->required();
  cmd->add_option("--out", a.out, "output BVH (written atomically)")->required();
}

int run_resample(const ResampleArgs& a) {
  if (!std::isfinite(a.fps) || !(a.fps >= 1) || !(a.fps <= 1000))
    throw kumite::Error("resample", "argument", fmt::format("--fps: {} must be within 1..1000", a.fps));
  const Clip clip = read_bvh(a.in);
  const Clip out = resample_clip(clip, 1.0 / a.fps);
  write_bvh(a.out, out);
  fmt::print("wrote {}: {} frames at {:g} fps from {} at {:g} fps\n", a.out, out.frame_count, a.fps, clip.frame_count,
             clip.frame_rate_hz());
  return 0;
}

// ---- strike --------------------------------------------------------------------------------

struct StrikeArgs {
  std::string db, character, order, target, out, report, trace;
};

void add_strike(CLI::App& app, StrikeArgs& a) {
  auto* cmd = app.add_subcommand("strike", "Retrieve and adapt one strike onto a character; write BVH + JSON");
  cmd->add_option("--db", a.db, "fighter.kdb")->required()->check(CLI::ExistingFile);
  cmd->add_option("--character", a.character, "character name (content/characters/<name>.bvh) or BVH file")->required();
  cmd->add_option("--order", a.order, "punch_right | punch_left | kick_right | kick_left")->required();
  cmd->add_option("--target", a.target, "X,Y,Z in metres, character ground frame (root on the floor, facing +Z)")
      ->required();
  cmd->add_option("--out", a.out, "strike.bvh (the adapted motion, character skeleton, source units)")->required();
  cmd->add_option("--report", a.report, "strike.json")->required();
  cmd->add_option("--trace", a.trace,
                  "trace.csv: per frame the fighter state, d(t) weight, the update's µs, and per foot the planting phase, the "
                  "motion's contact, the hold (weight, m) and the drawn ankle (m)");
}

Eigen::Vector3d parse_target(const std::string& text) {
  Eigen::Vector3d v;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v.x(), &v.y(), &v.z(), &extra) != 3 || !v.allFinite())
    throw kumite::Error("strike", "argument", fmt::format("--target: '{}' is not X,Y,Z in metres", text));
  return v;
}

int run_strike(const StrikeArgs& a) {
  const auto order = kumite::parse_order(a.order);
  if (!order || order->kind == kumite::OrderKind::select_character || order->kind > kumite::OrderKind::kick_right)
    throw kumite::Error("strike", "argument", fmt::format("--order: '{}' is not punch_right, punch_left, kick_right or kick_left", a.order));
  const Eigen::Vector3d target = parse_target(a.target);
  prepare_output("--out", a.out);
  prepare_output("--report", a.report);
  if (!a.trace.empty()) prepare_output("--trace", a.trace);
  auto db = std::make_shared<const Database>(load_database(a.db));
  const Rig rig = load_character_rig(a.character);
  const StrikeRecording rec = record_strike(db, rig, order->kind, target, g_fighter);
  if (rec.contact_frame < 0) {
    for (const auto& e : rec.events) fmt::print(stderr, "  {}\n", e);
    throw kumite::Error("strike", "no_strike", fmt::format("{}: no {} in the database", a.db, a.order));
  }
  Clip motion = rec.motion;
  motion.name = fs::path(a.out).stem().string();
  write_bvh(a.out, motion);
  nlohmann::json j;
  j["database"] = a.db;
  j["character"] = rig.name;
  j["order"] = a.order;
  j["clip"] = rec.source_clip;
  j["segment"] = rec.segment_name;
  j["mirrored"] = rec.mirrored;
  j["start_frame"] = rec.source_start_frame;
  j["segment_start_frame"] = rec.strike.plan.start_frame;
  j["segment_contact_frame"] = rec.strike.plan.contact_frame;
  j["contact_frame"] = rec.contact_frame;
  j["frames"] = motion.frame_count;
  j["frame_time_s"] = motion.frame_time_s;
  j["effector"] = rig.skeleton.names[static_cast<std::size_t>(rec.effector_joint)];
  j["target"] = {target.x(), target.y(), target.z()};
  const Eigen::Vector3d hit = rec.strike.target_room_m;  // room = ground frame here
  (void)hit;
  j["reachable"] = rec.strike.contact_reached;
  j["aim_lowered_m"] = rec.strike.aim_lowered_m;
  j["reach_error_m"] = rec.strike.contact_distance_m;
  j["hit"] = rec.strike.hit;
  j["target_reached"] = rec.strike.target_reached;
  j["body_distance_m"] = rec.strike.body_distance_m;
  j["hit_radius_m"] = g_fighter.hit_radius_m;
  j["retrieval_us"] = rec.retrieval_us;
  j["retrieval_cost"] = rec.strike.plan.choice.cost;
  j["target_in_box"] = rec.strike.plan.choice.target_in_box;
  const auto us = rec.update_us;
  j["adaptation_us"] = {{"mean", mean(us)}, {"p99", percentile(us, 99)}, {"max", percentile(us, 100)}};
  j["foot_slide_mm"] = rec.max_foot_slide_m * 1000;
  j["bvh_unit_m"] = motion.unit_m;
  j["events"] = rec.events;
  kumite::write_file_atomically(a.report, j.dump(2) + "\n");
  if (!a.trace.empty()) {
    std::string csv = "frame,state,ramp,root_drop_m,update_us";
    for (const char* side : {"l", "r"})
      csv += fmt::format(",{0}_phase,{0}_planted,{0}_lock_w,{0}_lock_x,{0}_lock_y,{0}_lock_z,{0}_ankle_x,{0}_ankle_y,{0}_ankle_z", side);
    csv += "\n";
    for (std::size_t f = 0; f < rec.trace.size(); ++f) {
      const auto& r = rec.trace[f];
      // Frame 0 (the rest pose at the origin) is not timed; frame f > 0 is update_us[f - 1].
      const double us_f = f > 0 && f - 1 < rec.update_us.size() ? rec.update_us[f - 1] : 0.0;
      csv += fmt::format("{},{},{:.4f},{:.4f},{:.2f}", f, kumite::content::to_string(r.state), r.ramp, r.root_drop_m, us_f);
      for (std::size_t s = 0; s < 2; ++s) {
        static constexpr const char* kPhase[] = {"free", "held", "swinging", "stepping", "landing"};
        csv += fmt::format(",{},{:.2f},{:.3f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f}", kPhase[static_cast<int>(r.phase[s])],
                           r.planted[s], r.lock_weight[s], r.lock_m[s].x(), r.lock_m[s].y(), r.lock_m[s].z(),
                           r.ankle_m[s].x(), r.ankle_m[s].y(), r.ankle_m[s].z());
      }
      csv += "\n";
    }
    kumite::write_file_atomically(a.trace, csv);
  }
  fmt::print("{} {} on {}: {} from {} f{}{}, contact at frame {} of {}: {} (reach error {:.2f} mm{}); wrote {} and {}\n",
             a.order, a.target, rig.name, rec.segment_name, rec.source_clip, rec.source_start_frame,
             rec.mirrored ? " (mirrored)" : "", rec.contact_frame, motion.frame_count, rec.strike.hit ? "hit" : "miss",
             rec.strike.contact_distance_m * 1000, rec.strike.contact_reached ? "" : ", target out of reach", a.out,
             a.report);
  return 0;
}

// ---- motion quality ------------------------------------------------------------------------
// What the eye sees: every figure is computed from joint positions of a BVH read back with
// read_bvh (the independent path), beside the same figure on the source clip (motion_quality.hpp).

const std::vector<std::string>& all_character_names() {
  static const std::vector<std::string> names{"aiko", "bruno", "kenji", "mei", "viktor"};
  return names;
}

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

/// n, p50, p95, max of the finite values.
nlohmann::json dist_json(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  return {{"n", v.size()}, {"p50", percentile(v, 50)}, {"p95", percentile(v, 95)}, {"max", percentile(v, 100)}};
}

std::string joint_label(const Skeleton& s, int j) {
  if (j < 0) return "";
  for (std::size_t c = 0; c < kCanonicalJointCount; ++c)
    if (s.canonical[c] == j)
      return fmt::format("{} ({})", s.names[static_cast<std::size_t>(j)], to_string(static_cast<CanonicalJoint>(c)));
  return s.names[static_cast<std::size_t>(j)];
}

/// The database's source clips, read from content/motions/<clip>.bvh (mirrored when asked),
/// with their joint positions and leg length (m, hip -> ankle along the bones).
class SourceClips {
 public:
  struct Entry {
    Clip clip;
    std::vector<Eigen::Vector3d> positions;
    double leg_m = 1;
    JointTrack track() const { return {&clip.skeleton, positions, clip.frame_count, clip.frame_time_s}; }
  };
  const Entry& get(const std::string& name, bool mirrored) {
    const std::string key = name + (mirrored ? "#mirror" : "");
    if (auto it = cache_.find(key); it != cache_.end()) return it->second;
    Entry e;
    e.clip = load_source_clip(name, mirrored, default_content_dir() / "motions");
    e.positions = all_joint_positions(e.clip);
    e.leg_m = measure_proportions(e.clip.skeleton).leg_m;
    return cache_.emplace(key, std::move(e)).first->second;
  }

 private:
  std::map<std::string, Entry> cache_;
};

nlohmann::json figures_json(const TrackFigures& f, const Skeleton& s, double frame_time_s) {
  nlohmann::json snaps = nlohmann::json::array();
  for (std::size_t i = 0; i < f.snaps.size() && i < 12; ++i)
    snaps.push_back({{"frame", f.snaps[i].frame}, {"joint", joint_label(s, f.snaps[i].joint)},
                     {"step_mm", f.snaps[i].step_m * 1000}, {"speed_mps", f.snaps[i].step_m / frame_time_s},
                     {"rule", std::string(1, f.snaps[i].rule)}});
  nlohmann::json flips = nlohmann::json::array();
  for (const auto& x : f.flips)
    flips.push_back({{"frame", x.frame}, {"limb", fmt::format("{} {}", x.side == kLeft ? "left" : "right", x.leg ? "knee" : "elbow")},
                     {"turn_deg", x.turn_deg}});
  auto foot = [](const FootFigure& ff) {
    return nlohmann::json{{"max_mps", num(ff.max_mps)}, {"p50_mps", num(ff.p50_mps)}, {"p95_mps", num(ff.p95_mps)},
                          {"frame", ff.frame}, {"frames", ff.frames}};
  };
  // The five fastest joints (max speed over the range).
  std::vector<int> order(f.speed.joint_max_mps.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::sort(order.begin(), order.end(), [&](int x, int y) {
    return f.speed.joint_max_mps[static_cast<std::size_t>(x)] > f.speed.joint_max_mps[static_cast<std::size_t>(y)];
  });
  nlohmann::json fastest = nlohmann::json::array();
  for (std::size_t i = 0; i < order.size() && i < 5; ++i)
    fastest.push_back({{"joint", joint_label(s, order[i])}, {"max_mps", f.speed.joint_max_mps[static_cast<std::size_t>(order[i])]}});
  return {{"joint_speed", {{"p50_mps", f.speed.p50_mps}, {"p99_mps", f.speed.p99_mps}, {"max_mps", f.speed.max_mps},
                           {"max_joint", joint_label(s, f.speed.max_joint)}, {"max_frame", f.speed.max_frame},
                           {"fastest_joints", fastest}}},
          {"snaps", f.snaps.size()}, {"snap_list", snaps},
          {"support_slide", {{"left", foot(f.slide[0])}, {"right", foot(f.slide[1])}}},
          {"lifted_where_source_stands", {{"left", foot(f.lifted[0])}, {"right", foot(f.lifted[1])}}},
          {"support_slide_source_contacts", {{"left", foot(f.slide_source_contacts[0])}, {"right", foot(f.slide_source_contacts[1])}}},
          {"stepping_peak", {{"left", foot(f.stepping[0])}, {"right", foot(f.stepping[1])}}},
          {"knee_flips", f.knee_flips()}, {"elbow_flips", f.elbow_flips()}, {"flip_list", flips},
          {"max_elbow_turn_deg", f.max_turn_deg[0]}, {"max_knee_turn_deg", f.max_turn_deg[1]}};
}

nlohmann::json limb_json(const LimbAtContact& l) {
  return {{"extension", l.extension}, {"end_ahead_m", l.end_ahead_m}, {"folded", l.folded},
          {"elbow_above_head", l.elbow_above_head}, {"approach_elevation_deg", l.approach_elevation_deg}, {"approach_above_line_deg", l.approach_above_line_deg},
          {"approach_max_elevation_deg", l.approach_max_elevation_deg},
          {"end_to_target_m", l.end_to_target_m}};
}

/// Aggregates over the strike grid (figures per strike: see motion_quality.hpp).
struct QualityTotals {
  int strikes = 0, no_strike = 0, punches = 0, kicks = 0;
  int snaps_out = 0, snaps_src = 0, snaps_whole = 0, snaps_tail = 0;
  int folded_punch_out = 0, folded_punch_src = 0, folded_kick_out = 0, folded_kick_src = 0;
  int elbow_above_head_out = 0, elbow_above_head_src = 0;
  int knee_flip_out = 0, knee_flip_src = 0, elbow_flip_out = 0, elbow_flip_src = 0;
  int reachable = 0, hits = 0;
  int slide_over_source = 0, lifted_strikes = 0;  ///< slide > source's + 0.3 m/s; a foot lifted where the source stands
  std::vector<double> lifted_out, slide_any_out, step_ratio_stepped, unsourced_step;
  int src_speed_on_bones = 0;  ///< strikes whose source speeds were measured on the character's bones
  std::vector<double> p99_ratio_leg_scaled;  ///< against the source's speeds scaled by leg length alone
  std::vector<double> p99_ratio, p99_out, p99_src, max_out, max_src, slide_out, slide_src, step_out, step_src,
      step_ratio, reach_m, elev_out, elev_src, ext_out, ext_src, whole_slide, tail_slide, whole_step, tail_step,
      knee_turn_out, knee_turn_src, elbow_turn_out, elbow_turn_src, kick_ext_out, kick_ext_src, hook_out, hook_src,
      above_line_out, above_line_src, aim_lowered;  ///< aim_lowered: m, punches aimed below the ordered target
  /// s: StrikeQuality::both_feet_off_excess_s of punches / kicks; m: toe_below_standing_m
  std::vector<double> off_excess_punch, off_excess_kick, toe_below;

  void add(const StrikeQuality& q, bool kick, bool reached, bool hit, double reach, double aim_lowered_m) {
    if (aim_lowered_m > 0) aim_lowered.push_back(aim_lowered_m);
    (kick ? off_excess_kick : off_excess_punch).push_back(q.both_feet_off_excess_s);
    toe_below.push_back(q.toe_below_standing_m);
    ++strikes;
    (kick ? kicks : punches)++;
    snaps_out += !q.output.snaps.empty();
    snaps_src += !q.source.snaps.empty();
    snaps_whole += !q.whole.snaps.empty();
    snaps_tail += !q.tail.snaps.empty();
    whole_slide.push_back(q.whole.max_slide_mps());
    whole_step.push_back(q.whole.max_stepping_mps());
    if (q.tail_range.count() > 0) {
      tail_slide.push_back(q.tail.max_slide_mps());
      tail_step.push_back(q.tail.max_stepping_mps());
    }
    knee_turn_out.push_back(q.output.max_turn_deg[1]);
    knee_turn_src.push_back(q.source.max_turn_deg[1]);
    elbow_turn_out.push_back(q.output.max_turn_deg[0]);
    elbow_turn_src.push_back(q.source.max_turn_deg[0]);
    if (kick) {
      folded_kick_out += q.output_contact.folded;
      folded_kick_src += q.source_contact.folded;
    } else {
      folded_punch_out += q.output_contact.folded;
      folded_punch_src += q.source_contact.folded;
      elbow_above_head_out += q.output_contact.elbow_above_head;
      elbow_above_head_src += q.source_contact.elbow_above_head;
      elev_out.push_back(q.output_contact.approach_elevation_deg);
      elev_src.push_back(q.source_contact.approach_elevation_deg);
      above_line_out.push_back(q.output_contact.approach_above_line_deg);
      above_line_src.push_back(q.source_contact.approach_above_line_deg);
      hook_out.push_back(q.output_contact.approach_max_elevation_deg);
      hook_src.push_back(q.source_contact.approach_max_elevation_deg);
    }
    knee_flip_out += q.output.knee_flips() > 0;
    knee_flip_src += q.source.knee_flips() > 0;
    elbow_flip_out += q.output.elbow_flips() > 0;
    elbow_flip_src += q.source.elbow_flips() > 0;
    p99_out.push_back(q.output.speed.p99_mps);
    p99_src.push_back(q.source.speed.p99_mps);
    p99_ratio.push_back(q.output.speed.p99_mps / std::max(1e-9, q.source.speed.p99_mps));
    p99_ratio_leg_scaled.push_back(q.output.speed.p99_mps / std::max(1e-9, q.source_speed_leg_scaled.p99_mps));
    src_speed_on_bones += q.source_speed_on_output_bones;
    max_out.push_back(q.output.speed.max_mps);
    max_src.push_back(q.source.speed.max_mps);
    slide_out.push_back(q.output.max_slide_mps());
    slide_src.push_back(q.source.max_slide_mps());
    slide_any_out.push_back(q.output.max_slide_source_contacts_mps());
    lifted_out.push_back(q.output.max_lifted_mps());
    lifted_strikes += std::isfinite(q.output.max_lifted_mps());
    // Per foot: its slide against the source's same foot over the same frames (issue 12: never
    // more than 0.3 m/s above it).
    bool over = false;
    for (int s = 0; s < 2; ++s) {
      const double o = q.output.slide[static_cast<std::size_t>(s)].max_mps, r = q.source.slide[static_cast<std::size_t>(s)].max_mps;
      if (std::isfinite(o) && o > (std::isfinite(r) ? r : 0.0) + 0.3) over = true;
    }
    slide_over_source += over;
    step_out.push_back(q.output.max_stepping_mps());
    step_src.push_back(q.source.max_stepping_mps());
    step_ratio.push_back(q.output.max_stepping_mps() / q.source.max_stepping_mps());
    // Per foot: where the source steps it (its peak >= kSourceSteps_mps), the ratio of the
    // drawn foot's peak to the source's; where the source does not, the drawn foot's peak (a
    // step the source has none of: back to the rest stance, into a strike's stance).
    constexpr double kSourceSteps_mps = 0.5;
    for (int s = 0; s < 2; ++s) {
      const double o = q.output.stepping[static_cast<std::size_t>(s)].max_mps, r = q.source.stepping[static_cast<std::size_t>(s)].max_mps;
      if (!std::isfinite(o)) continue;
      if (std::isfinite(r) && r >= kSourceSteps_mps) {
        step_ratio_stepped.push_back(o / r);
      } else {
        unsourced_step.push_back(o);
      }
    }
    (kick ? kick_ext_out : ext_out).push_back(q.output_contact.extension);
    (kick ? kick_ext_src : ext_src).push_back(q.source_contact.extension);
    reach_m.push_back(reach);
    reachable += reached;
    hits += hit;
  }

  nlohmann::json json() const {
    return {{"strikes", strikes}, {"no_strike", no_strike}, {"punches", punches}, {"kicks", kicks},
            {"strikes_with_snaps", snaps_out}, {"source_strikes_with_snaps", snaps_src},
            {"strikes_with_snaps_whole_bvh", snaps_whole}, {"strikes_with_snaps_in_tail", snaps_tail},
            {"whole_bvh_support_slide_mps", dist_json(whole_slide)}, {"tail_support_slide_mps", dist_json(tail_slide)},
            {"whole_bvh_stepping_peak_mps", dist_json(whole_step)}, {"tail_stepping_peak_mps", dist_json(tail_step)},
            {"max_knee_turn_deg", dist_json(knee_turn_out)}, {"source_max_knee_turn_deg", dist_json(knee_turn_src)},
            {"max_elbow_turn_deg", dist_json(elbow_turn_out)}, {"source_max_elbow_turn_deg", dist_json(elbow_turn_src)},
            {"joint_speed_p99_mps", dist_json(p99_out)}, {"source_joint_speed_p99_mps", dist_json(p99_src)},
            {"joint_speed_p99_ratio", dist_json(p99_ratio)},
            {"joint_speed_p99_ratio_leg_scaled", dist_json(p99_ratio_leg_scaled)},
            {"source_speeds_on_character_bones", src_speed_on_bones},
            {"joint_speed_max_mps", dist_json(max_out)}, {"source_joint_speed_max_mps", dist_json(max_src)},
            {"support_slide_mps", dist_json(slide_out)}, {"source_support_slide_mps", dist_json(slide_src)},
            {"strikes_slide_over_source_plus_0_3", slide_over_source},
            {"support_slide_source_contacts_mps", dist_json(slide_any_out)},
            {"strikes_lifted_where_source_stands", lifted_strikes},
            {"punch_both_feet_off_excess_s", dist_json(off_excess_punch)},
            {"kick_both_feet_off_excess_s", dist_json(off_excess_kick)},
            {"punches_both_feet_off_over_source_0_1s", std::count_if(off_excess_punch.begin(), off_excess_punch.end(), [](double e) { return e > 0.1; })},
            {"kicks_both_feet_off_over_source_0_1s", std::count_if(off_excess_kick.begin(), off_excess_kick.end(), [](double e) { return e > 0.1; })},
            {"toe_below_standing_m", dist_json(toe_below)},
            {"strikes_toe_below_standing_over_2cm", std::count_if(toe_below.begin(), toe_below.end(), [](double t) { return t > 0.02; })},
            {"lifted_where_source_stands_mps", dist_json(lifted_out)},
            {"stepping_peak_mps", dist_json(step_out)}, {"source_stepping_peak_mps", dist_json(step_src)},
            {"stepping_peak_ratio", dist_json(step_ratio)},
            {"stepping_peak_ratio_where_source_steps", dist_json(step_ratio_stepped)},
            {"feet_where_source_steps_over_1_2x",
             std::count_if(step_ratio_stepped.begin(), step_ratio_stepped.end(), [](double r) { return r > 1.2; })},
            {"stepping_peak_where_source_does_not_step_mps", dist_json(unsourced_step)},
            {"folded_punches", folded_punch_out}, {"source_folded_punches", folded_punch_src},
            {"elbow_above_head", elbow_above_head_out}, {"source_elbow_above_head", elbow_above_head_src},
            {"folded_kicks", folded_kick_out}, {"source_folded_kicks", folded_kick_src},
            {"strikes_with_knee_flip", knee_flip_out}, {"source_strikes_with_knee_flip", knee_flip_src},
            {"strikes_with_elbow_flip", elbow_flip_out}, {"source_strikes_with_elbow_flip", elbow_flip_src},
            {"punch_approach_elevation_deg", dist_json(elev_out)},
            {"source_punch_approach_elevation_deg", dist_json(elev_src)},
            {"punch_approach_above_arm_line_deg", dist_json(above_line_out)},
            {"source_punch_approach_above_arm_line_deg", dist_json(above_line_src)},
            {"punch_approach_max_elevation_deg", dist_json(hook_out)},
            {"source_punch_approach_max_elevation_deg", dist_json(hook_src)},
            {"punch_extension_at_contact", dist_json(ext_out)}, {"source_punch_extension_at_contact", dist_json(ext_src)},
            {"kick_extension_at_contact", dist_json(kick_ext_out)},
            {"source_kick_extension_at_contact", dist_json(kick_ext_src)},
            {"reach_m", dist_json(reach_m)},
            {"reachable_pct", strikes ? 100.0 * reachable / strikes : 0.0},
            {"punches_aimed_lower", aim_lowered.size()},
            {"aim_lowered_m", dist_json(aim_lowered)},
            {"hit_pct", strikes ? 100.0 * hits / strikes : 0.0}};
  }

  void print() const {
    const nlohmann::json j = json();
    auto d = [&](const char* k, const char* f) { return j[k][f].get<double>(); };
    fmt::print("strikes: {} ({} punches, {} kicks), {} orders found no strike\n", strikes, punches, kicks, no_strike);
    fmt::print("strikes with a one-frame snap: {} of {} over the compared frames (source clips, same frames: {}); "
               "{} over the whole BVH, {} in the tail after the strike\n",
               snaps_out, strikes, snaps_src, snaps_whole, snaps_tail);
    fmt::print("joint speed p99 output/source (the source laid on the character's bones, {} of {} strikes; the rest "
               "scaled by leg length): p50 {:.2f} p95 {:.2f} max {:.2f} (source scaled by leg length alone: p95 {:.2f} max "
               "{:.2f}); max joint speed p50 {:.1f} max {:.1f} m/s (source p50 {:.1f} max {:.1f})\n",
               src_speed_on_bones, strikes,
               d("joint_speed_p99_ratio", "p50"), d("joint_speed_p99_ratio", "p95"), d("joint_speed_p99_ratio", "max"),
               d("joint_speed_p99_ratio_leg_scaled", "p95"), d("joint_speed_p99_ratio_leg_scaled", "max"),
               d("joint_speed_max_mps", "p50"), d("joint_speed_max_mps", "max"), d("source_joint_speed_max_mps", "p50"),
               d("source_joint_speed_max_mps", "max"));
    fmt::print("support-foot slide (source contacts, the drawn foot down): p50 {:.2f} p95 {:.2f} max {:.2f} m/s; source "
               "p50 {:.2f} p95 {:.2f} max {:.2f} m/s; strikes more than 0.3 m/s above the source's: {}\n",
               d("support_slide_mps", "p50"), d("support_slide_mps", "p95"), d("support_slide_mps", "max"),
               d("source_support_slide_mps", "p50"), d("source_support_slide_mps", "p95"),
               d("source_support_slide_mps", "max"), slide_over_source);
    fmt::print("  a foot off the floor where the source stands (a step or late landing): {} strikes, horizontal speed p50 "
               "{:.2f} max {:.2f} m/s; every source-contact frame (lifted or down): p95 {:.2f} max {:.2f} m/s\n",
               lifted_strikes, d("lifted_where_source_stands_mps", "p50"), d("lifted_where_source_stands_mps", "max"),
               d("support_slide_source_contacts_mps", "p95"), d("support_slide_source_contacts_mps", "max"));
    fmt::print("  both feet off the floor beyond the source (at the rate played) over the same frames: punches {} of {} "
               "more than 0.1 s (p95 {:.2f} max {:.2f} s), kicks {} of {} (p95 {:.2f} max {:.2f} s); toes below where "
               "they stand: p95 {:.3f} max {:.3f} m, {} strikes over 2 cm\n",
               j["punches_both_feet_off_over_source_0_1s"].get<int>(), punches, d("punch_both_feet_off_excess_s", "p95"),
               d("punch_both_feet_off_excess_s", "max"), j["kicks_both_feet_off_over_source_0_1s"].get<int>(), kicks,
               d("kick_both_feet_off_excess_s", "p95"), d("kick_both_feet_off_excess_s", "max"),
               d("toe_below_standing_m", "p95"), d("toe_below_standing_m", "max"), j["strikes_toe_below_standing_over_2cm"].get<int>());
    fmt::print("whole BVH, geometric contacts: support-foot slide p50 {:.2f} p95 {:.2f} max {:.2f} m/s, stepping-foot peak "
               "p50 {:.2f} max {:.2f} m/s; tail only: slide p95 {:.2f}, stepping max {:.2f} m/s ({} strikes with a tail)\n",
               d("whole_bvh_support_slide_mps", "p50"), d("whole_bvh_support_slide_mps", "p95"),
               d("whole_bvh_support_slide_mps", "max"), d("whole_bvh_stepping_peak_mps", "p50"),
               d("whole_bvh_stepping_peak_mps", "max"), d("tail_support_slide_mps", "p95"),
               d("tail_stepping_peak_mps", "max"), j["tail_support_slide_mps"]["n"].get<int>());
    fmt::print("stepping-foot peak: p50 {:.2f} max {:.2f} m/s; source p50 {:.2f} max {:.2f} m/s; ratio p50 {:.2f} max {:.2f}\n",
               d("stepping_peak_mps", "p50"), d("stepping_peak_mps", "max"), d("source_stepping_peak_mps", "p50"),
               d("source_stepping_peak_mps", "max"), d("stepping_peak_ratio", "p50"), d("stepping_peak_ratio", "max"));
    fmt::print("  feet the source steps (its peak >= 0.5 m/s): {} , ratio p50 {:.2f} p95 {:.2f} max {:.2f}, {} over 1.2x; "
               "feet the source does not step: {}, drawn peak p50 {:.2f} max {:.2f} m/s\n",
               j["stepping_peak_ratio_where_source_steps"]["n"].get<int>(), d("stepping_peak_ratio_where_source_steps", "p50"),
               d("stepping_peak_ratio_where_source_steps", "p95"), d("stepping_peak_ratio_where_source_steps", "max"),
               j["feet_where_source_steps_over_1_2x"].get<int>(), j["stepping_peak_where_source_does_not_step_mps"]["n"].get<int>(),
               d("stepping_peak_where_source_does_not_step_mps", "p50"), d("stepping_peak_where_source_does_not_step_mps", "max"));
    fmt::print("folded at contact: punches {} of {} (elbow above head {}), kicks {} of {}; source: punches {} (elbow above "
               "head {}), kicks {}\n",
               folded_punch_out, punches, elbow_above_head_out, folded_kick_out, kicks, folded_punch_src,
               elbow_above_head_src, folded_kick_src);
    fmt::print("limb flips (> 90 deg in 33 ms, bent >= 20 deg): strikes with a knee flip {} (source {}), with an elbow flip "
               "{} (source {}); largest bend-plane turn in 33 ms: knee p50 {:.0f} max {:.0f} deg (source max {:.0f}), "
               "elbow p50 {:.0f} max {:.0f} deg (source max {:.0f})\n",
               knee_flip_out, knee_flip_src, elbow_flip_out, elbow_flip_src, d("max_knee_turn_deg", "p50"),
               d("max_knee_turn_deg", "max"), d("source_max_knee_turn_deg", "max"), d("max_elbow_turn_deg", "p50"),
               d("max_elbow_turn_deg", "max"), d("source_max_elbow_turn_deg", "max"));
    fmt::print("punch approach, largest elevation in the last 0.1 s: p50 {:.0f} p95 {:.0f} max {:.0f} deg (source p50 {:.0f} "
               "p95 {:.0f} max {:.0f})\n",
               d("punch_approach_max_elevation_deg", "p50"), d("punch_approach_max_elevation_deg", "p95"),
               d("punch_approach_max_elevation_deg", "max"), d("source_punch_approach_max_elevation_deg", "p50"),
               d("source_punch_approach_max_elevation_deg", "p95"), d("source_punch_approach_max_elevation_deg", "max"));
    fmt::print("punch approach elevation (last 33 ms): p50 {:.0f} p95 {:.0f} deg (source p50 {:.0f} p95 {:.0f}); limb extension at "
               "contact p50: punches {:.2f} (source {:.2f}), kicks {:.2f} (source {:.2f})\n",
               d("punch_approach_elevation_deg", "p50"), d("punch_approach_elevation_deg", "p95"),
               d("source_punch_approach_elevation_deg", "p50"), d("source_punch_approach_elevation_deg", "p95"),
               d("punch_extension_at_contact", "p50"), d("source_punch_extension_at_contact", "p50"),
               d("kick_extension_at_contact", "p50"), d("source_kick_extension_at_contact", "p50"));
    fmt::print("punch approach above the arm's line at contact (last 33 ms; 0 = along the arm): p50 {:.0f} p95 {:.0f} deg "
               "(source p50 {:.0f} p95 {:.0f})\n",
               d("punch_approach_above_arm_line_deg", "p50"), d("punch_approach_above_arm_line_deg", "p95"),
               d("source_punch_approach_above_arm_line_deg", "p50"), d("source_punch_approach_above_arm_line_deg", "p95"));
    fmt::print("reach (hit point to target, read back): p50 {:.1f} mm, max {:.1f} mm; reachable {:.1f} % (solver), hits "
               "{:.1f} %\n",
               d("reach_m", "p50") * 1000, d("reach_m", "max") * 1000, j["reachable_pct"].get<double>(),
               j["hit_pct"].get<double>());
    if (!aim_lowered.empty())
      fmt::print("punches aimed below the ordered target (a straight arm to it lifts the elbow over the head; reach is "
                 "to the aim): {} of {}, lowered p50 {:.0f} mm, max {:.0f} mm\n",
                 aim_lowered.size(), punches, d("aim_lowered_m", "p50") * 1000, d("aim_lowered_m", "max") * 1000);
  }
};

/// Runs the quality grid: record_strike, write (or format) the BVH, read it back, compare
/// with the source clip. Returns one JSON object per strike.
nlohmann::json measure_grid(const std::shared_ptr<const Database>& db, const std::vector<Rig>& rigs, int targets,
                            const std::string& bvh_dir, QualityTotals& totals, const std::string& rest = {}) {
  nlohmann::json out = nlohmann::json::array();
  SourceClips sources;
  const auto grid = quality_grid(rigs, targets);
  if (!bvh_dir.empty()) fs::create_directories(bvh_dir);
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const StrikeCase& sc = grid[i];
    const Rig& rig = rigs[static_cast<std::size_t>(sc.character)];
    const bool kick = sc.order == kumite::OrderKind::kick_left || sc.order == kumite::OrderKind::kick_right;
    nlohmann::json js{{"character", rig.name}, {"order", std::string(kumite::to_string(sc.order))},
                      {"target", {sc.target_m.x(), sc.target_m.y(), sc.target_m.z()}}};
    const StrikeRecording rec = record_strike(db, rig, sc.order, sc.target_m, g_fighter, rest);
    if (rec.contact_frame < 0) {
      ++totals.no_strike;
      js["struck"] = false;
      out.push_back(js);
      continue;
    }
    Clip motion = rec.motion;
    motion.name = fmt::format("{:03}-{}-{}", i, rig.name, kumite::to_string(sc.order));
    Clip back;
    if (!bvh_dir.empty()) {
      const fs::path path = fs::path(bvh_dir) / (motion.name + ".bvh");
      write_bvh(path, motion);
      back = read_bvh(path);
      js["bvh"] = path.string();
    } else {
      back = parse_bvh(format_bvh(motion), motion.name + ".bvh");
    }
    const std::vector<Eigen::Vector3d> positions = all_joint_positions(back);
    const JointTrack track{&back.skeleton, positions, back.frame_count, back.frame_time_s};
    const SourceClips::Entry& src = sources.get(rec.source_clip, rec.mirrored);
    const JointTrack src_track = src.track();
    const StrikeComparisonInput in = strike_comparison_input(
        *db, rec, sc.order, track, src_track, measure_proportions(back.skeleton).leg_m, src.leg_m);
    const StrikeQuality q = compare_strike(in);
    totals.add(q, kick, rec.strike.contact_reached, rec.strike.hit, q.output_contact.end_to_target_m,
               rec.strike.aim_lowered_m);
    js["struck"] = true;
    js["segment"] = rec.segment_name;
    js["clip"] = rec.source_clip;
    js["mirrored"] = rec.mirrored;
    js["frames"] = back.frame_count;
    js["contact_frame"] = rec.contact_frame;
    js["output_frames"] = {q.output_range.first, q.output_range.last};
    js["source_frames"] = {q.source_range.first, q.source_range.last};
    js["speed_scale"] = q.speed_scale;
    js["source_speed_baseline"] = q.source_speed_on_output_bones ? "source laid on the character's bones" : "source x speed_scale";
    js["source_p99_mps_leg_scaled"] = q.source_speed_leg_scaled.p99_mps;
    js["rate"] = rec.strike.rate;
    js["rate_lead_frames"] = rec.strike.rate_lead_updates;
    js["reachable"] = rec.strike.contact_reached;
    js["aim_lowered_m"] = rec.strike.aim_lowered_m;
    js["hit"] = rec.strike.hit;
    js["solver_reach_error_m"] = rec.strike.contact_distance_m;
    js["reach_m"] = q.output_contact.end_to_target_m;
    js["output"] = figures_json(q.output, back.skeleton, back.frame_time_s);
    js["source"] = figures_json(q.source, src.clip.skeleton, src.clip.frame_time_s);
    js["whole"] = figures_json(q.whole, back.skeleton, back.frame_time_s);
    js["tail_frames"] = {q.tail_range.first, q.tail_range.last};
    if (q.tail_range.count() > 0) js["tail"] = figures_json(q.tail, back.skeleton, back.frame_time_s);
    js["output_contact"] = limb_json(q.output_contact);
    js["both_feet_off_s"] = {{"output", q.output_both_feet_off_s}, {"source", q.source_both_feet_off_s}, {"excess", q.both_feet_off_excess_s}};
    js["toe_below_standing_m"] = q.toe_below_standing_m;
    js["source_contact"] = limb_json(q.source_contact);
    out.push_back(js);
  }
  return out;
}

std::vector<Rig> load_rigs(const std::vector<std::string>& names) {
  std::vector<Rig> rigs;
  for (const auto& n : names) rigs.push_back(load_character_rig(n));
  return rigs;
}

struct QualityArgs {
  std::string db, out, bvh_dir, rest;
  std::vector<std::string> characters = all_character_names();
  int targets = 12;
};

void add_quality(CLI::App& app, QualityArgs& a) {
  auto* cmd = app.add_subcommand("quality", "Strike grid (characters x 4 orders x targets): each strike's BVH read back, "
                                            "figures a viewer sees beside the source clip's; prints a summary, writes JSON");
  cmd->add_option("--db", a.db, "fighter.kdb")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", a.out, "quality.json")->required();
  cmd->add_option("--characters", a.characters, "character names or BVH files")->delimiter(',')->capture_default_str();
  cmd->add_option("--targets", a.targets, "targets per character and order")->capture_default_str()->check(CLI::Range(1, 1000));
  cmd->add_option("--rest", a.rest,
                  "the rest segment each strike starts from (default: the database's first; e.g. its ':mirror', or the "
                  "rest a stance step ends in, 135_03_rest_3)");
  cmd->add_option("--bvh-dir", a.bvh_dir, "also write each strike's BVH here (read back from the file)");
}

int run_quality(const QualityArgs& a) {
  prepare_output("--out", a.out);
  const double t0 = now_s();
  auto db = std::make_shared<const Database>(load_database(a.db));
  const std::vector<Rig> rigs = load_rigs(a.characters);
  QualityTotals totals;
  nlohmann::json strikes = measure_grid(db, rigs, a.targets, a.bvh_dir, totals, a.rest);
  nlohmann::json j;
  j["database"] = a.db;
  j["characters"] = a.characters;
  j["targets_per_order"] = a.targets;
  j["summary"] = totals.json();
  j["strikes"] = std::move(strikes);
  j["seconds"] = now_s() - t0;
  kumite::write_file_atomically(a.out, j.dump(2) + "\n");
  totals.print();
  fmt::print("wrote {} ({:.1f} s)\n", a.out, now_s() - t0);
  return 0;
}

// ---- bout ------------------------------------------------------------------------------------
// A scripted bout: Behaviour driven at 60 Hz by a SYNTHETIC visitor head (walking side to side,
// stepping closer and farther, a crouch, a dodge) and a list of orders (strikes, character
// switches). Writes one BVH per run of one character and the figures over the whole bout.

Eigen::Vector3d synthetic_head(double t, const FighterConfig& config) {
  auto bump = [](double time, double a, double b, double ramp) {  // 0 -> 1 -> 0, smooth edges
    auto s = [](double x) { x = std::clamp(x, 0.0, 1.0); return x * x * (3 - 2 * x); };
    return s((time - a) / ramp) * (1 - s((time - (b - ramp)) / ramp));
  };
  const double pi = 3.14159265358979323846;
  double x = 0.7 * std::sin(2 * pi * t / 9);
  const double z = config.home.z() + 1.4 + 0.35 * std::sin(2 * pi * t / 13);
  const double y = 1.70 - 0.40 * bump(t, 8.0, 10.5, 0.5);  // crouch
  x += 0.45 * bump(t, 13.5, 14.3, 0.25);                    // dodge sideways
  return {x, y, z};
}

/// SYNTHETIC: a visitor who walks toward the fighter and away in stages (no orders are
/// given): forward and back walks of 0.3-1.1 m at ~0.8 m/s, each followed by a pause, and a
/// slow sideways drift. For judging how the fighter follows (stance steps from the mocap).
Eigen::Vector3d walking_head(double t, const FighterConfig& config) {
  // (time s, distance walked away from the fighter m): straight walks between the knots.
  static constexpr std::array<std::array<double, 2>, 15> kKnots = {{{0, 0},    {2, 0},    {3.0, 0.8},  {6, 0.8},
                                                                    {7.3, -0.3}, {10, -0.3}, {10.5, 0.1}, {13, 0.1},
                                                                    {14.4, 1.2}, {17, 1.2}, {18.2, 0.3}, {21, 0.3},
                                                                    {22.3, -0.2}, {25, -0.2}, {26, 0.4}}};
  const double tc = std::fmod(t, 28.0);
  double d = kKnots.back()[1];
  for (std::size_t i = 1; i < kKnots.size(); ++i) {
    if (tc <= kKnots[i][0]) {
      const double u = (tc - kKnots[i - 1][0]) / (kKnots[i][0] - kKnots[i - 1][0]);
      const double w = u * u * (3 - 2 * u);  // eased walk
      d = kKnots[i - 1][1] + w * (kKnots[i][1] - kKnots[i - 1][1]);
      break;
    }
  }
  const double pi = 3.14159265358979323846;
  // Within the fighter's default depth limits: the spot it keeps (0.9 m short of the head)
  // lies 0.6 m behind home at d = 0 and 0.9 m ahead of that at d = 1.2.
  return {config.home.x() + 0.25 * std::sin(2 * pi * t / 23), 1.70, config.home.z() + 0.3 + d};
}

struct BoutOrder {
  double t;
  kumite::OrderKind kind;
  int character = -1;
};
std::vector<BoutOrder> bout_orders() {
  using K = kumite::OrderKind;
  return {{1.5, K::punch_right}, {3.0, K::kick_left}, {4.5, K::punch_left}, {6.0, K::select_character, 1},
          {7.0, K::kick_right}, {8.8, K::punch_right}, {10.8, K::select_character, 3}, {11.6, K::punch_left},
          {13.7, K::punch_right}, {15.0, K::kick_right}, {15.25, K::select_character, 4}, {17.0, K::kick_left},
          {18.4, K::punch_left}, {19.3, K::punch_right}};
}

struct BoutResult {
  nlohmann::json report;
  std::vector<Clip> runs;
};

/// Plays the bout. `out_bvh` empty: the runs' BVH are formatted and parsed back in memory.
BoutResult run_bout_scenario(const std::shared_ptr<const Database>& db, std::vector<Rig> rigs, double seconds,
                             const std::string& out_bvh, bool walking_visitor = false) {
  const FighterConfig config = g_fighter;
  Behaviour b(db, rigs, config);  // rigs stay ours: the run skeletons come from them
  const double dt = 1.0 / 60;
  struct Contact {
    int frame;
    Effector effector;
    Eigen::Vector3d target;
    FighterEvent::Kind outcome;  ///< hit, dodged or miss
  };
  struct Run {
    int character;
    Clip clip;
    int first_frame;
    std::vector<Contact> contacts;
  };
  std::vector<Run> runs;
  // The drawn canonical joints over the whole bout (switch easing included).
  Skeleton canon;
  for (std::size_t c = 0; c < kCanonicalJointCount; ++c) {
    canon.names.emplace_back(to_string(static_cast<CanonicalJoint>(c)));
    canon.parents.push_back(-1);
    canon.offsets.emplace_back(0, 0, 0);
    canon.end_site.push_back(false);
    canon.canonical[c] = static_cast<int>(c);
  }
  std::vector<Eigen::Vector3d> drawn;
  std::vector<std::string> events;
  std::map<std::string, int> state_frames;
  std::vector<kumite::content::FighterState> frame_state;  // per bout frame
  std::vector<std::array<double, 2>> source_planted;  // per bout frame: the motion played's own contacts
  int stance_step_frames = 0;  // frames a stance step from the mocap played
  struct StanceStepPlayed {
    int update;       // stance_steps_begun() while it played
    int segment;
    int frame;        // bout frame it began
    int run;          // run index, and the run's frame it began
    int run_frame;
    int frames;       // frames it played (until the rest motion took over, or a strike)
    double scale;
  };
  std::vector<StanceStepPlayed> stance_steps;
  auto orders = walking_visitor ? std::vector<BoutOrder>{} : bout_orders();
  std::size_t next_order = 0;
  const int frames = static_cast<int>(std::lround(seconds / dt));
  for (int i = 0; i < frames; ++i) {
    const double t = i * dt;
    const Eigen::Vector3d head = walking_visitor ? walking_head(t, config) : synthetic_head(t, config);
    while (next_order < orders.size() && orders[next_order].t <= t) {
      const BoutOrder& o = orders[next_order++];
      b.order(kumite::Order{t, o.kind, o.character});
    }
    b.update(t, dt, head);
    // Public API only: frame(), current_character(), local_rotations(), root_position(),
    // take_events().
    const FighterFrame frame = b.frame();
    const int c = b.current_character();
    const Rig& rig = rigs[static_cast<std::size_t>(c)];
    if (runs.empty() || runs.back().character != c) {
      Run r;
      r.character = c;
      r.first_frame = i;
      r.clip.name = fmt::format("{:02}-{}", runs.size() + 1, rig.name);
      r.clip.skeleton = rig.skeleton;
      r.clip.unit_m = rig.unit_m;
      r.clip.frame_time_s = dt;
      runs.push_back(std::move(r));
    }
    Run& run = runs.back();
    const auto n = static_cast<std::size_t>(rig.joint_count());
    run.clip.root_positions.push_back(b.root_position());
    run.clip.local_rotations.insert(run.clip.local_rotations.end(), b.local_rotations().begin(),
                                    b.local_rotations().begin() + static_cast<std::ptrdiff_t>(n));
    ++run.clip.frame_count;
    CanonicalPose cp;
    canonical_positions(rig.skeleton, frame.joints.first(n), cp);  // what is drawn (switch easing included)
    drawn.insert(drawn.end(), cp.begin(), cp.end());
    ++state_frames[std::string(to_string(frame.state))];
    frame_state.push_back(frame.state);
    source_planted.push_back(b.motion_planted());
    if (b.stance_step_segment() >= 0) {
      ++stance_step_frames;
      if (stance_steps.empty() || stance_steps.back().update != b.stance_steps_begun())
        stance_steps.push_back({b.stance_steps_begun(), b.stance_step_segment(), i, static_cast<int>(runs.size()) - 1,
                                run.clip.frame_count - 1, 0, b.stance_step_scale()});
      ++stance_steps.back().frames;
    }
    for (const auto& e : b.take_events()) {
      events.push_back(fmt::format("{:.3f} s: {}: {}", t, to_string(e.kind), b.describe(e)));
      // Every strike that came to contact is judged there, a dodged one too: the visitor sees
      // its limb at full extension all the same.
      if ((e.kind == FighterEvent::Kind::hit || e.kind == FighterEvent::Kind::dodged ||
           e.kind == FighterEvent::Kind::miss) && frame.target)
        run.contacts.push_back({run.clip.frame_count - 1, effector_of_order(e.order.kind), *frame.target, e.kind});
    }
  }
  BoutResult result;
  nlohmann::json jr = nlohmann::json::array();
  /// Contact frames a run's foot needs for its slide percentiles to count in the bout's worst
  /// (a third of a second at 60 Hz).
  constexpr int kMinPercentileFrames = 20;
  std::vector<double> slide_max, slide_p95, slide_p50, step_max;
  int snaps = 0, knee_flips = 0, elbow_flips = 0, folded = 0, strikes = 0, hits = 0, dodged = 0, misses = 0;
  int both_off_frames = 0;  // frames with both feet off the floor (the drawn joints, each run's own floor)
  // ...by what the fighter was doing: a strike's may be its clip's own (a hop in the mocap:
  // the grid compares those with the source); resting and following play the rest motion,
  // which stands on both feet, so every one there is the fighter's own.
  std::map<std::string, int> both_off_by_state;
  // ...and of those, the frames where the motion played (the one blended to) has a foot down
  // by its own contacts (detected on the mocap, stored in the database) within
  // kSourceOffSlack frames: off the floor where the source is not (both_feet_off_source_down).
  constexpr int kSourceOffSlack = 3;  // frames (50 ms at 60 Hz): the drawn and source detections differ by a frame or two
  int both_off_beyond_source = 0;
  std::map<std::string, int> beyond_source_by_state;
  for (Run& run : runs) {
    Clip back;
    std::string file;
    if (!out_bvh.empty()) {
      const fs::path p(out_bvh);
      file = (p.parent_path() / fmt::format("{}.{}{}", p.stem().string(), run.clip.name, p.extension().string())).string();
      write_bvh(file, run.clip);
      back = read_bvh(file);
    } else {
      back = parse_bvh(format_bvh(run.clip), run.clip.name + ".bvh");
    }
    const std::vector<Eigen::Vector3d> positions = all_joint_positions(back);
    const JointTrack track{&back.skeleton, positions, back.frame_count, back.frame_time_s};
    const FootContacts contacts = detect_foot_contacts(track);
    const TrackFigures f = track_figures(track, {0, back.frame_count - 1}, contacts, 1);
    nlohmann::json off_json = nlohmann::json::array();
    const auto state_at = [&](int k) { return std::string(to_string(frame_state[static_cast<std::size_t>(run.first_frame + k)])); };
    for (const FrameRange& r : both_feet_off(track, {0, back.frame_count - 1}, contacts)) {
      both_off_frames += r.count();
      for (int k = r.first; k <= r.last; ++k) ++both_off_by_state[state_at(k)];
      const std::vector<int> beyond = both_feet_off_source_down(std::span(&r, 1), run.first_frame, source_planted, kSourceOffSlack);
      both_off_beyond_source += static_cast<int>(beyond.size());
      for (const int k : beyond) ++beyond_source_by_state[state_at(k)];
      off_json.push_back({{"t_s", (run.first_frame + r.first) * dt}, {"frames", r.count()}, {"frames_source_down", beyond.size()},
                          {"state", state_at(r.first)}});
    }
    nlohmann::json jc = nlohmann::json::array();
    const int h = speed_half_window(back.frame_time_s);
    for (const Contact& c : run.contacts) {
      const LimbAtContact l = limb_at_contact(track, c.effector, c.frame, c.target, h);
      folded += l.folded;
      ++strikes;
      hits += c.outcome == FighterEvent::Kind::hit;
      dodged += c.outcome == FighterEvent::Kind::dodged;
      misses += c.outcome == FighterEvent::Kind::miss;
      nlohmann::json x = limb_json(l);
      x["frame"] = c.frame;
      x["hit"] = c.outcome == FighterEvent::Kind::hit;
      x["outcome"] = to_string(c.outcome);
      x["limb"] = fmt::format("{} {}", c.effector.side == kLeft ? "left" : "right", c.effector.leg ? "leg" : "arm");
      jc.push_back(x);
    }
    snaps += static_cast<int>(f.snaps.size());
    knee_flips += f.knee_flips();
    elbow_flips += f.elbow_flips();
    for (int s = 0; s < 2; ++s) {
      slide_max.push_back(f.slide[static_cast<std::size_t>(s)].max_mps);
      // A run's p50 / p95 only over enough contact frames to be one (kMinPercentileFrames): a
      // run with one contact frame gave its speed as the bout's "worst p95".
      if (f.slide[static_cast<std::size_t>(s)].frames >= kMinPercentileFrames) {
        slide_p95.push_back(f.slide[static_cast<std::size_t>(s)].p95_mps);
        slide_p50.push_back(f.slide[static_cast<std::size_t>(s)].p50_mps);
      }
      step_max.push_back(f.stepping[static_cast<std::size_t>(s)].max_mps);
    }
    nlohmann::json j{{"character", rigs[static_cast<std::size_t>(run.character)].name}, {"first_frame", run.first_frame},
                     {"frames", back.frame_count}, {"figures", figures_json(f, back.skeleton, back.frame_time_s)},
                     {"low_fast_frames", {contacts.low_fast_frames[0], contacts.low_fast_frames[1]}},
                     {"contacts", jc}, {"both_feet_off", off_json}};
    if (!file.empty()) j["bvh"] = file;
    jr.push_back(j);
    result.runs.push_back(std::move(back));
  }
  const JointTrack drawn_track{&canon, drawn, frames, dt};
  const auto drawn_snaps = find_snaps(drawn_track, {0, frames - 1});
  const SpeedStats drawn_speed = joint_speeds(drawn_track, {0, frames - 1});
  nlohmann::json ds = nlohmann::json::array();
  for (std::size_t i = 0; i < drawn_snaps.size() && i < 20; ++i)
    ds.push_back({{"frame", drawn_snaps[i].frame}, {"joint", canon.names[static_cast<std::size_t>(drawn_snaps[i].joint)]},
                  {"step_mm", drawn_snaps[i].step_m * 1000}, {"rule", std::string(1, drawn_snaps[i].rule)}});
  auto mx = [](const std::vector<double>& v) { return num(dist_json(v)["max"].get<double>()); };
  nlohmann::json js = nlohmann::json::array();
  for (const StanceStepPlayed& st : stance_steps) {
    const MotionSegment& seg = db->segments[static_cast<std::size_t>(st.segment)];
    js.push_back({{"segment", seg.name}, {"source_clip", seg.source_clip}, {"source_first_frame", seg.source_first_frame},
                  {"source_frames", seg.frame_count()}, {"source_frame_time_s", seg.frame_time_s}, {"mirrored", seg.mirrored},
                  {"travel_scale", st.scale}, {"frame", st.frame}, {"run", st.run + 1}, {"run_frame", st.run_frame},
                  {"frames_played", st.frames}});
  }
  result.report = {
      {"stance_step_list", js},
      {"visitor", walking_visitor ? "SYNTHETIC walking visitor (walking_head in kumite_motion.cpp): walks of 0.3-1.1 m "
                                    "toward and away, pauses between, no orders"
                                  : "SYNTHETIC head trajectory (synthetic_head in kumite_motion.cpp): side to side, "
                                    "closer/farther, a crouch at 8-10.5 s, a dodge at 13.5-14.3 s"},
      {"seconds", seconds}, {"frame_time_s", dt}, {"frames", frames}, {"state_frames", state_frames},
      {"summary",
       {{"runs", runs.size()}, {"strikes", strikes}, {"hits", hits}, {"dodged", dodged}, {"misses", misses},
        {"stance_steps", b.stance_steps_begun()},
        {"stance_step_frames", stance_step_frames}, {"snaps_in_bvh_runs", snaps},
        {"drawn_snaps_whole_bout", drawn_snaps.size()}, {"drawn_joint_speed_p99_mps", drawn_speed.p99_mps},
        {"drawn_joint_speed_max_mps", drawn_speed.max_mps},
        {"drawn_joint_speed_max_joint", canon.names[static_cast<std::size_t>(std::max(0, drawn_speed.max_joint))]},
        {"drawn_joint_speed_max_frame", drawn_speed.max_frame},
        {"support_slide_max_mps", mx(slide_max)}, {"support_slide_p95_mps_worst_run", mx(slide_p95)},
        {"support_slide_p50_mps_worst_run", mx(slide_p50)},
        {"support_slide_percentiles_min_frames", kMinPercentileFrames}, {"stepping_peak_max_mps", mx(step_max)},
        {"knee_flips", knee_flips}, {"elbow_flips", elbow_flips}, {"folded_at_contact", folded},
        {"both_feet_off_frames", both_off_frames}, {"both_feet_off_frames_by_state", both_off_by_state},
        {"both_feet_off_frames_source_down", both_off_beyond_source},
        {"both_feet_off_frames_source_down_by_state", beyond_source_by_state}}},
      {"drawn_snap_list", ds}, {"runs", jr}, {"events", events}};
  return result;
}

struct BoutArgs {
  std::string db, out, report;
  double seconds = 20;
  std::string visitor = "bout";
  std::vector<std::string> characters = all_character_names();
};

void add_bout(CLI::App& app, BoutArgs& a) {
  auto* cmd = app.add_subcommand("bout", "A scripted bout (SYNTHETIC visitor, strikes, character switches) at 60 Hz: "
                                         "one BVH per character run (<out stem>.NN-name.bvh) and the figures as JSON");
  cmd->add_option("--db", a.db, "fighter.kdb")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", a.out, "bout.bvh: runs are written as bout.01-<character>.bvh, ...")->required();
  cmd->add_option("--report", a.report, "bout.json")->required();
  cmd->add_option("--seconds", a.seconds, "length of the bout (s)")->capture_default_str()->check(CLI::Range(1.0, 600.0));
  cmd->add_option("--characters", a.characters, "character names or BVH files (order = select_character index)")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--visitor", a.visitor,
                  "bout: the scripted bout (orders, switches); walk: a visitor walking toward and away, no orders (one character)")
      ->check(CLI::IsMember({"bout", "walk"}))->capture_default_str();
}

int run_bout(const BoutArgs& a) {
  prepare_output("--out", a.out);
  prepare_output("--report", a.report);
  auto db = std::make_shared<const Database>(load_database(a.db));
  const BoutResult r = run_bout_scenario(db, load_rigs(a.characters), a.seconds, a.out, a.visitor == "walk");
  kumite::write_file_atomically(a.report, r.report.dump(2) + "\n");
  fmt::print("{}\nwrote {} and {} character runs beside {}\n", r.report["summary"].dump(2), a.report, r.runs.size(), a.out);
  return 0;
}

// ---- spar ---------------------------------------------------------------------------------

struct SparArgs {
  std::string db, report;
  double minutes = 10;
  std::vector<std::string> presets = {"aggressive_unskilled", "defensive_skilled"};
  std::string character = "kenji";
  double visitor_strike_rate = 0.3;  ///< 1/s, the scripted visitor's strikes
  std::string visitor = "openings";  ///< openings: strikes only while the fighter is idle; any: at any time
  std::uint64_t seed = 1;
};

void add_spar(CLI::App& app, SparArgs& a) {
  auto* cmd = app.add_subcommand("spar", "The sparring planner against a scripted SYNTHETIC visitor (recognised strikes at "
                                         "random times) per preset, at 60 Hz: its attack rate, counter probability and "
                                         "reaction delay measured beside the configured ones, as JSON");
  cmd->add_option("--db", a.db, "fighter.kdb")->required()->check(CLI::ExistingFile);
  cmd->add_option("--report", a.report, "spar.json")->required();
  cmd->add_option("--minutes", a.minutes, "simulated minutes per preset")->capture_default_str()->check(CLI::Range(0.1, 120.0));
  cmd->add_option("--presets", a.presets, "planner presets (aggressive_unskilled, defensive_skilled)")
      ->delimiter(',')->capture_default_str();
  cmd->add_option("--character", a.character, "character name or BVH file")->capture_default_str();
  cmd->add_option("--visitor-strike-rate", a.visitor_strike_rate, "the visitor's strikes per second")
      ->capture_default_str()->check(CLI::Range(0.0, 5.0));
  cmd->add_option("--seed", a.seed, "the run's seed (the planner's and the visitor's draws)")->capture_default_str();
  cmd->add_option("--visitor", a.visitor,
                  "openings: the visitor's strike timer runs only while the fighter is idle (strikes it can answer); "
                  "any: at any time, also mid-strike")
      ->check(CLI::IsMember({"openings", "any"}))->capture_default_str();
}

int run_spar(const SparArgs& a) {
  prepare_output("--report", a.report);
  nlohmann::json report = {{"visitor", fmt::format("SYNTHETIC: stands 1.5 m in front of the fighter's home, sways, strikes at "
                                                   "exponential random times at {}/s {} (recognised begin events; no body drawn)",
                                                   a.visitor_strike_rate,
                                                   a.visitor == "openings" ? "of the time the fighter is idle" : "at any time")},
                           {"minutes", a.minutes}, {"seed", a.seed}, {"presets", nlohmann::json::object()}};
  for (const std::string& name : a.presets) {
    const std::optional<PlannerTunables> preset = planner_preset(name);
    if (!preset) throw kumite::Error("spar", "--presets", fmt::format("--presets: no preset named '{}'", name));
    FighterConfig cfg = g_fighter;
    cfg.database = a.db;
    const fs::path file = fs::exists(a.character) ? fs::path(a.character)
                                                  : default_content_dir() / "characters" / (a.character + ".bvh");
    cfg.characters = {file};
    cfg.character_names = {a.character};
    cfg.planner = *preset;
    auto fighter = Fighter::create(cfg);
    // The visitor's own draws (SplitMix64 on another stream than the planner's).
    std::uint64_t visitor_draws = 0;
    const auto visitor_uniform = [&] {
      return unit_interval(splitmix64((a.seed ^ 0x5bd1e995u) + 0x9E3779B97F4A7C15ull * visitor_draws++));
    };
    const double dt = 1.0 / 60;
    const int updates = static_cast<int>(std::lround(a.minutes * 60 / dt));
    // s left on the visitor's strike timer (openings: it runs only while the fighter is idle).
    double strike_left = a.visitor_strike_rate > 0 ? -std::log1p(-visitor_uniform()) / a.visitor_strike_rate : 1e18;
    bool idle = true;
    FighterOutput out;
    std::vector<VisitorStrikeSeen> strikes;
    // The updates run back to back (simulated time), so an update may wait for the retrieval
    // worker's plan or playback rate, which a 60 Hz frame loop gives 16.7 ms to be ready:
    // step_us is each update's wall time with that wait, step_us_without_waits without it.
    std::vector<double> step_us, step_us_own;
    step_us.reserve(static_cast<std::size_t>(updates));
    step_us_own.reserve(static_cast<std::size_t>(updates));
    std::map<std::string, int> events;
    for (int k = 0; k < updates; ++k) {
      FighterInput in;
      in.now = 1.0 + k * dt;
      in.dt_s = k == 0 ? 0.0 : dt;
      in.seed = a.seed;
      in.head_m = Eigen::Vector3d(0.15 * std::sin(0.4 * in.now), 1.65, -1.0);
      strikes.clear();
      if (k > 0 && (idle || a.visitor == "any")) strike_left -= dt;
      if (strike_left <= 0) {
        VisitorStrikeSeen v;
        v.t = in.now;
        v.type = kumite::recognition::EventType::begin;
        const double u = visitor_uniform();
        v.limb = u < 0.4 ? kumite::recognition::Role::right_hand : u < 0.8 ? kumite::recognition::Role::left_hand : kumite::recognition::Role::right_foot;
        v.action = u < 0.8 ? kumite::recognition::Action::straight_punch : kumite::recognition::Action::front_kick;
        v.progress = 0;
        v.confidence = 1;
        v.impact_m = in.head_m + Eigen::Vector3d(0, -0.1, -0.7);
        strikes.push_back(v);
        strike_left = -std::log1p(-visitor_uniform()) / a.visitor_strike_rate;
      }
      in.strikes = strikes;
      const double waited_before_ms = fighter->retrieval_timing().wait_total_ms;
      const auto t0 = std::chrono::steady_clock::now();
      fighter->step(in, out);
      step_us.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
      step_us_own.push_back(step_us.back() - 1e3 * (fighter->retrieval_timing().wait_total_ms - waited_before_ms));
      for (const auto& e : out.events) ++events[std::string(to_string(e.kind))];
      idle = out.frame.action == FighterAction::idle;
    }
    const Fighter::PlannerStatus st = fighter->planner_status();
    const PlannerCounts& c = st.counts;
    const auto ratio = [](double x, double y) { return y > 0 ? x / y : 0.0; };
    report["presets"][name] = {
        {"configured", {{"attack_rate_per_s", preset->attack_rate_per_s}, {"counter_probability", preset->counter_probability},
                        {"reaction_time_s", preset->reaction_time_s}}},
        {"measured",
         {{"attack_rate_per_s", ratio(c.attacks, c.timer_running_s)},
          {"attack_rate_spread_per_s",
           c.timer_running_s > 0 ? std::sqrt(preset->attack_rate_per_s * c.timer_running_s) / c.timer_running_s : 0.0},
          {"attack_rate_note", "its own attacks per second of the time its timer ran (engaged, the fighter idle); spread, the "
                               "standard error of such a rate over that time (a Poisson count: sqrt(rate x time) / time)"},
          {"counter_probability_drawn", ratio(c.counters_drawn, c.visitor_strikes)},
          {"counter_probability_ordered", ratio(c.counters, c.visitor_strikes)},
          {"counter_probability_spread",
           c.visitor_strikes > 0 ? std::sqrt(preset->counter_probability * (1 - preset->counter_probability) / c.visitor_strikes) : 0.0},
          {"counter_note", "drawn: visitor strikes drawn to be countered; ordered: counters the fighter was idle to give within "
                           "counter_deadline_s (a counter still due when a newer strike is drawn answers that one instead); "
                           "spread, the standard error of a share of that many draws (sqrt(p (1 - p) / strikes))"},
          {"reaction_time_s_ordered", ratio(c.reaction_sum_s, c.counters)},
          {"reaction_time_s_drawn", ratio(c.reaction_drawn_sum_s, c.counters)},
          {"reaction_time_s_spread", c.counters > 0 ? preset->reaction_time_s / std::sqrt(static_cast<double>(c.counters)) : 0.0},
          {"reaction_note", "mean delay visitor strike -> counter order over the counters ordered: ordered, as given (at the update "
                            "nearest the due time, after waiting for the fighter to be idle); drawn, the planner's exponential draws alone; spread, the standard error of "
                            "such a mean of that many draws (reaction_time_s / sqrt(counters))"}}},
        {"counts",
         {{"attacks", c.attacks}, {"visitor_strikes_engaged", c.visitor_strikes}, {"counters_drawn", c.counters_drawn},
          {"counters", c.counters}, {"counters_dropped", c.counters_dropped}, {"counters_superseded", c.counters_superseded},
          {"engaged_s", c.engaged_s},
          {"timer_running_s", c.timer_running_s}}},
        {"fighter_events", events},
        {"step_us", stats_json(step_us)},
        {"step_us_without_waits", stats_json(step_us_own)},
        {"worker_waits", fighter->retrieval_timing().waits},
        {"step_note", "us per fighter update, back to back: step_us with the waits for the retrieval worker (a plan or "
                      "a playback rate not ready by its update), step_us_without_waits without them (a 60 Hz frame loop "
                      "gives the worker 16.7 ms)"}};
  }
  kumite::write_file_atomically(a.report, report.dump(2) + "\n");
  fmt::print("{}\nwrote {}\n", report["presets"].dump(2), a.report);
  return 0;
}

// ---- hits ---------------------------------------------------------------------------------
// Hit reactions against a SYNTHETIC visitor: scripted blows of its right fist into the sparring
// fighter's drawn head or torso. Each blow's figures are judged on the drawn joints beside a
// run the same in everything up to that blow, with the fist held still where the blow starts.

struct HitsArgs {
  std::string db, out, report;
  std::string character = "kenji";
};

void add_hits(CLI::App& app, HitsArgs& a) {
  auto* cmd = app.add_subcommand("hits", "Hit reactions: SYNTHETIC blows into the sparring fighter's head and torso (and a "
                                         "slow touch, and a blow during its own punch); the fighter's BVH and, per blow, the "
                                         "struck point's move beside a run without it, as JSON");
  cmd->add_option("--db", a.db, "fighter.kdb")->required()->check(CLI::ExistingFile);
  cmd->add_option("--out", a.out, "hits.bvh (the fighter, every blow)")->required();
  cmd->add_option("--report", a.report, "hits.json")->required();
  cmd->add_option("--character", a.character, "character name or BVH file")->capture_default_str();
}

namespace {
struct ScriptedBlow {
  std::string label;
  double at_s = 0;           ///< s: the fist starts 0.30 m in front of its aim
  CanonicalJoint aim = CanonicalJoint::head;
  double aside_m = 0;        ///< m toward the fighter's left shoulder (negative: right)
  double speed_mps = 0;
  bool punch_first = false;  ///< the fighter is ordered a right punch 3 updates before (its own strike under way)
  // Found from the run without it:
  int k0 = -1;
  Eigen::Vector3d start{0, 0, 0}, dir{0, 0, -1};
};
struct HitsRun {
  Clip clip;
  std::vector<std::vector<Eigen::Vector3d>> joints;
  std::vector<FighterAction> actions;
  std::vector<std::pair<int, FighterEvent>> events;
};
constexpr double kHitsDt = 1.0 / 60;
const Eigen::Vector3d kHitsVisitorHead(0, 1.65, -1.6);
const Eigen::Vector3d kHitsGuard(-0.15, 1.45, -1.8);

/// The session with `blows` (those with k0 set); `held`: the last one's fist stays where it starts.
HitsRun run_hits(const FighterConfig& cfg, const Rig& rig, const std::vector<ScriptedBlow>& blows, bool held, int updates) {
  auto f = Fighter::create(cfg);
  HitsRun r;
  r.clip.name = "hits";
  r.clip.skeleton = rig.skeleton;
  r.clip.unit_m = rig.unit_m;
  r.clip.frame_time_s = kHitsDt;
  const auto n = static_cast<std::size_t>(rig.joint_count());
  FighterOutput out;
  constexpr double kTravel_m = 0.45, kStill_s = 0.3;
  for (int k = 0; k < updates; ++k) {
    FighterInput in;
    in.now = k * kHitsDt;
    in.dt_s = k ? kHitsDt : 0;
    in.head_m = kHitsVisitorHead;
    Eigen::Vector3d fist = kHitsGuard;
    bool tracked = true;
    std::vector<kumite::Order> orders;
    for (std::size_t i = 0; i < blows.size(); ++i) {
      const ScriptedBlow& b = blows[i];
      if (b.k0 < 0) continue;
      if (b.punch_first && k == b.k0 - 3) orders.push_back(kumite::Order{in.now, kumite::OrderKind::punch_right, 0});
      if (k < b.k0) continue;
      const double gone = kHitsDt * (k - b.k0);
      const bool last = held && i + 1 == blows.size();
      const double travel_s = kTravel_m / b.speed_mps;
      if (last || gone <= travel_s + kStill_s) {
        fist = b.start + b.dir * (last ? 0.0 : std::min(kTravel_m, b.speed_mps * gone));
      } else if (gone <= travel_s + kStill_s + 2 * kHitsDt) {
        tracked = false;  // lost a moment, then back at the guard (no way through the body judged)
      }
    }
    std::vector<VisitorBody> bodies(2);
    bodies[0].role = kumite::recognition::Role::head;
    bodies[0].position_m = kHitsVisitorHead;
    bodies[0].tracked = true;
    bodies[0].t = in.now;
    bodies[1].role = kumite::recognition::Role::right_hand;
    bodies[1].position_m = fist;
    bodies[1].tracked = tracked;
    bodies[1].t = in.now;
    in.bodies = bodies;
    in.orders = orders;
    f->step(in, out);
    r.joints.emplace_back(out.frame.joints.begin(), out.frame.joints.end());
    r.actions.push_back(out.frame.action);
    for (const FighterEvent& e : out.events) r.events.emplace_back(k, e);
    r.clip.root_positions.push_back(out.frame.root_joint);
    r.clip.local_rotations.insert(r.clip.local_rotations.end(), out.frame.local_rotations.begin(),
                                  out.frame.local_rotations.begin() + static_cast<std::ptrdiff_t>(n));
    ++r.clip.frame_count;
  }
  return r;
}
}  // namespace

int run_hits(const HitsArgs& a) {
  prepare_output("--out", a.out);
  prepare_output("--report", a.report);
  using CJ = CanonicalJoint;
  FighterConfig cfg = g_fighter;
  cfg.database = a.db;
  const fs::path file = fs::exists(a.character) ? fs::path(a.character) : default_content_dir() / "characters" / (a.character + ".bvh");
  cfg.characters = {file};
  cfg.character_names = {a.character};
  cfg.planner.mode = PlannerMode::spar;
  cfg.planner.attack_rate_per_s = 0;
  cfg.planner.counter_probability = 0;
  const Rig rig = load_character_rig(file.string());
  const int updates = 60 * 19;
  std::vector<ScriptedBlow> script = {
      {"head, 4 m/s", 3.0, CJ::head, 0, 4.0},
      {"head, slow touch 1 m/s (under hit_min_speed_mps)", 5.0, CJ::head, 0, 1.0},
      {"torso 0.12 m left of the midline, 9 m/s (full: steps back)", 7.0, CJ::chest, 0.12, 9.0},
      {"head, 6 m/s, during its own right punch", 11.0, CJ::head, 0, 6.0, true},
      {"torso 0.12 m right of the midline, 5 m/s", 15.0, CJ::chest, -0.12, 5.0},
  };
  nlohmann::json blows_json = nlohmann::json::array();
  std::vector<ScriptedBlow> done;
  std::vector<HitsRun> without;
  for (ScriptedBlow b : script) {
    // Aimed from the run with the blows before it (and this one's fist held where it starts).
    ScriptedBlow probe = b;
    probe.k0 = static_cast<int>(std::lround(b.at_s / kHitsDt));
    probe.start = kHitsGuard;
    std::vector<ScriptedBlow> before = done;
    before.push_back(probe);
    const HitsRun pre = run_hits(cfg, rig, before, true, probe.k0);
    Eigen::Vector3d aim = pre.joints.back()[static_cast<std::size_t>(rig.skeleton.index(b.aim))];
    const Eigen::Vector3d across =
        (pre.joints.back()[static_cast<std::size_t>(rig.skeleton.index(CJ::l_shoulder))] -
         pre.joints.back()[static_cast<std::size_t>(rig.skeleton.index(CJ::r_shoulder))]).normalized();
    aim += across * b.aside_m;
    Eigen::Vector3d u = kHitsVisitorHead - aim;
    u.y() = 0;
    u.normalize();
    b.k0 = probe.k0;
    b.start = aim + u * 0.30;
    b.dir = -u;
    done.push_back(b);
    without.push_back(run_hits(cfg, rig, done, true, updates));
  }
  const HitsRun with = run_hits(cfg, rig, done, false, updates);
  for (std::size_t i = 0; i < done.size(); ++i) {
    const ScriptedBlow& b = done[i];
    const HitsRun& w = without[i];
    int kh = -1;
    for (const auto& [k, e] : with.events)
      if (kh < 0 && k >= b.k0 && k < b.k0 + 30 && e.kind == EventKind::visitor_hit) kh = k;
    const auto diff = [&](int k, std::size_t j) {
      return Eigen::Vector3d(with.joints[static_cast<std::size_t>(k)][j] - w.joints[static_cast<std::size_t>(k)][j]);
    };
    // The first update (from the blow's start) whose drawn joints differ from the run without it.
    int first_moved = -1;
    double most_diff = 0;
    const int end = i + 1 < done.size() ? done[i + 1].k0 : updates;
    for (int k = b.k0; k < end; ++k)
      for (std::size_t j = 0; j < with.joints[0].size(); ++j) {
        const double d = diff(k, j).norm();
        most_diff = std::max(most_diff, d);
        if (d > 0 && first_moved < 0) first_moved = k;
      }
    nlohmann::json bj = {{"label", b.label}, {"start_update", b.k0}, {"fist_speed_mps", b.speed_mps},
                         {"fist_dir", {b.dir.x(), b.dir.y(), b.dir.z()}}, {"struck_joint", std::string(to_string(b.aim))},
                         {"visitor_hit_update", kh}, {"first_update_drawn_differently", first_moved},
                         {"largest_joint_difference_m", most_diff}};
    if (kh >= 0) {
      const auto j = static_cast<std::size_t>(rig.skeleton.index(b.aim));
      const Eigen::Vector3d first = diff(kh, j);
      double peak = 0;
      int peak_at = kh;
      for (int k = kh; k < std::min(end, kh + 30); ++k)
        if (diff(k, j).dot(b.dir) > peak) peak = diff(k, j).dot(b.dir), peak_at = k;
      bj["struck_point_on_contact_frame_m"] = {first.x(), first.y(), first.z()};
      bj["struck_point_along_blow_on_contact_frame_m"] = first.dot(b.dir);
      bj["struck_point_along_blow_peak_m"] = peak;
      bj["peak_frames_after_contact"] = peak_at - kh;
      bj["joints_before_contact_identical"] = first_moved < 0 || first_moved >= kh;
      const int kr = static_cast<int>(std::find(with.actions.begin() + kh, with.actions.end(), FighterAction::recovering) -
                                      with.actions.begin());
      if (b.punch_first) {
        int kc = -1;
        for (const auto& [k, e] : w.events)
          if (kc < 0 && k >= b.k0 && (e.kind == EventKind::hit || e.kind == EventKind::dodged || e.kind == EventKind::miss)) kc = k;
        bool contact = false;
        for (const auto& [k, e] : with.events)
          if (k >= b.k0 && k < end && (e.kind == EventKind::hit || e.kind == EventKind::dodged || e.kind == EventKind::miss)) contact = true;
        bj["own_punch_contact_update_without_blow"] = kc;
        bj["own_punch_left_for_rest_update"] = kr;
        bj["own_punch_reached_contact"] = contact;
      }
    }
    blows_json.push_back(bj);
  }
  write_bvh(a.out, with.clip);
  nlohmann::json report = {
      {"visitor", "SYNTHETIC: head still at (0, 1.65, -1.6) m; its right fist at a guard, then per blow from 0.30 m in front of "
                  "the fighter's drawn joint (+ aside along its shoulders) straight at it from the visitor's side for 0.45 m, "
                  "held 0.3 s, lost two updates, back at the guard"},
      {"fighter", {{"character", a.character}, {"mode", "spar"}, {"attack_rate_per_s", 0}, {"counter_probability", 0}}},
      {"frame_rate_hz", 60}, {"bvh", a.out}, {"blows", blows_json}};
  kumite::write_file_atomically(a.report, report.dump(2) + "\n");
  fmt::print("{}\nwrote {} and {}\n", blows_json.dump(2), a.report, a.out);
  return 0;
}

// ---- bench ---------------------------------------------------------------------------------

struct BenchArgs {
  std::string db;
  std::string annotations = (default_content_dir() / "motions" / "motions.toml").string();
  int queries = 2000;
  int scaled_clips = 10000;
  double feature_noise = 0.02;   ///< feature units (positions / leg length): ~2 cm on a 1 m leg
  double window_noise_m = 0.02;  ///< m, hit window shift per replica
  bool skip_adaptation = false;
  int quality_targets = 12;  ///< motion-quality grid targets per character and order (0: skip)
  double bout_seconds = 20;  ///< scripted bout length (0: skip)
  int adaptation_passes = 3;  ///< each strike recorded this many times; per frame the least time
};

void add_bench(CLI::App& app, BenchArgs& a) {
  auto* cmd = app.add_subcommand("bench", "Time retrieval (shipped and a scaled 10,000-clip database, vs brute force) "
                                          "and adaptation per frame; prints JSON");
  cmd->add_option("--db", a.db, "fighter.kdb (default: build from --annotations)");
  cmd->add_option("--annotations", a.annotations, "motions.toml")->capture_default_str();
  cmd->add_option("--queries", a.queries, "queries per measurement")->capture_default_str();
  cmd->add_option("--scaled-clips", a.scaled_clips, "strike clips in the scaled database")->capture_default_str();
  cmd->add_option("--feature-noise", a.feature_noise, "replica pose-feature noise (feature units)")->capture_default_str();
  cmd->add_option("--window-noise", a.window_noise_m, "replica hit-window noise (m)")->capture_default_str();
  cmd->add_flag("--skip-adaptation", a.skip_adaptation, "time retrieval only");
  cmd->add_option("--adaptation-passes", a.adaptation_passes,
                  "record each strike this many times (the same inputs, the same frames) and keep each frame's least "
                  "time: what the update costs, without the machine's interruptions (adaptation_us_per_frame_one_pass: "
                  "the first pass alone)")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  cmd->add_option("--quality-targets", a.quality_targets, "motion-quality grid: targets per character and order (0: skip)")
      ->capture_default_str()->check(CLI::Range(0, 1000));
  cmd->add_option("--bout-seconds", a.bout_seconds, "scripted bout for motion_quality.bout (0: skip)")
      ->capture_default_str()->check(CLI::Range(0.0, 600.0));
}

// Realistic queries: the fighter's pose at rest (each character), targets around head height.
std::vector<StrikeRequest> bench_requests(const Database& db, const std::vector<Rig>& rigs, int count, std::mt19937& rng) {
  std::vector<StrikeRequest> out;
  std::uniform_real_distribution<double> u(-1, 1);
  const auto rest = find_segment(db, SegmentKind::rest).value_or(0);
  const MotionSegment& seg = db.segments[static_cast<std::size_t>(rest)];
  for (int i = 0; i < count; ++i) {
    const Rig& rig = rigs[static_cast<std::size_t>(i) % rigs.size()];
    const int f = 1 + static_cast<int>((u(rng) + 1) * 0.5 * (seg.frame_count() - 2));
    StrikeRequest r;
    r.id = static_cast<std::uint64_t>(i);
    r.group = i % kGroupCount;
    r.now = seg.frames[static_cast<std::size_t>(f)];
    r.before = seg.frames[static_cast<std::size_t>(f - 1)];
    r.dt_s = seg.frame_time_s;
    const double h = rig.morphology.height_m;
    const bool kick = r.group >= 2;
    r.target_local_m = Eigen::Vector3d(0.2 * u(rng), (kick ? 0.6 : 0.9) * h + 0.1 * u(rng), 0.4 * h + 0.1 * u(rng));
    r.character_leg_length_m = rig.morphology.leg_length_m;
    out.push_back(r);
  }
  return out;
}

int run_bench(const BenchArgs& a) {
  auto db = std::make_shared<const Database>(a.db.empty() ? build_from_annotations(a.annotations, false)
                                                          : load_database(a.db));
  std::vector<Rig> rigs;
  for (const char* n : {"aiko", "bruno", "kenji", "mei", "viktor"}) rigs.push_back(load_character_rig(n));
  std::mt19937 rng(1);
  nlohmann::json j;
  j["database"] = a.db.empty() ? a.annotations : a.db;

  // 1. Retrieval over the shipped database: full planning (retarget onto the actor,
  //    features, search) per query.
  const StrikePlanner planner(db, g_fighter.retrieval);
  const auto requests = bench_requests(*db, rigs, a.queries, rng);
  std::vector<double> plan_us, search_us, brute_us;
  for (const auto& r : requests) plan_us.push_back(planner.plan(r).retrieval_us);
  int mismatches = 0;
  for (const auto& r : requests) {
    const RetrievalQuery q = planner.make_query(r);
    double t0 = now_s();
    const RetrievalChoice fast = retrieve(db->index, q, planner.tunables());
    search_us.push_back((now_s() - t0) * 1e6);
    t0 = now_s();
    const RetrievalChoice brute = retrieve_brute_force(db->index, q, planner.tunables());
    brute_us.push_back((now_s() - t0) * 1e6);
    mismatches += fast.row != brute.row;
  }
  j["shipped"] = {{"rows", db->index.size}, {"clusters", db->index.clusters.size()},
                  {"retrieval_us", stats_json(plan_us)}, {"search_us", stats_json(search_us)},
                  {"brute_force_us", stats_json(brute_us)}, {"mismatches_vs_brute_force", mismatches}};

  // 2. Scaled database: replicas of the shipped strikes with perturbed features and hit
  //    windows, `scaled_clips` strike clips in all.
  int strike_segments = 0;
  for (const auto& s : db->segments) strike_segments += s.kind == SegmentKind::strike;
  const int copies = (a.scaled_clips + strike_segments - 1) / std::max(1, strike_segments);
  double t0 = now_s();
  const RetrievalIndex big = replicated_index(db->index, copies, a.feature_noise, a.window_noise_m, 7);
  const double build_s = now_s() - t0;
  std::vector<double> fast_us, slow_us;
  std::vector<RetrievalQuery> queries;
  for (const auto& r : requests) queries.push_back(planner.make_query(r));
  mismatches = 0;
  long costed = 0, visited = 0, blocks_considered = 0, blocks_visited = 0;
  int in_box = 0;
  std::vector<double> in_box_us, fallback_us;
  // Each search in its own loop (neither evicts the other's data between queries).
  std::vector<RetrievalChoice> fast_choices;
  for (const auto& q : queries) {
    RetrievalStats st;
    t0 = now_s();
    const RetrievalChoice fast = retrieve(big, q, planner.tunables(), &st);
    fast_us.push_back((now_s() - t0) * 1e6);
    fast_choices.push_back(fast);
    (fast.target_in_box ? in_box_us : fallback_us).push_back(fast_us.back());
    in_box += fast.target_in_box;
    costed += st.rows_costed;
    visited += st.rows_visited;
    blocks_considered += st.blocks_considered;
    blocks_visited += st.blocks_visited;
  }
  for (std::size_t i = 0; i < queries.size(); ++i) {
    t0 = now_s();
    const RetrievalChoice brute = retrieve_brute_force(big, queries[i], planner.tunables());
    slow_us.push_back((now_s() - t0) * 1e6);
    mismatches += fast_choices[i].row != brute.row || fast_choices[i].cost != brute.cost;
  }
  j["scaled"] = {{"clips", copies * strike_segments}, {"rows", big.size}, {"clusters", big.clusters.size()},
                 {"index_build_s", build_s}, {"search_us", stats_json(fast_us)}, {"brute_force_us", stats_json(slow_us)},
                 {"speedup_median", percentile(slow_us, 50) / std::max(1e-9, percentile(fast_us, 50))},
                 {"speedup_p99", percentile(slow_us, 99) / std::max(1e-9, percentile(fast_us, 99))},
                 {"rows_costed_mean", static_cast<double>(costed) / static_cast<double>(queries.size())},
                 {"rows_visited_mean", static_cast<double>(visited) / static_cast<double>(queries.size())},
                 {"blocks", big.blocks.size()},
                 {"blocks_considered_mean", static_cast<double>(blocks_considered) / static_cast<double>(queries.size())},
                 {"blocks_visited_mean", static_cast<double>(blocks_visited) / static_cast<double>(queries.size())},
                 {"queries_target_in_box", in_box}, {"search_in_box_us", stats_json(in_box_us)},
                 {"search_fallback_us", stats_json(fallback_us)}, {"feature_noise", a.feature_noise}, {"window_noise_m", a.window_noise_m},
                 {"mismatches_vs_brute_force", mismatches},
                 {"brute_force_method", "retrieve_brute_force: a loop over the effector's rows for the box filter (stops "
                                        "at the first box holding the target, else finds the nearest box distance), "
                                        "then a loop computing the full cost of each eligible row; same cost, no index"}};

  // 3. Adaptation per frame (blend + retarget + reach + feet), strikes on every character.
  std::uniform_real_distribution<double> u(-1, 1);
  const kumite::OrderKind kinds[4] = {kumite::OrderKind::punch_right, kumite::OrderKind::punch_left,
                                      kumite::OrderKind::kick_right, kumite::OrderKind::kick_left};
  // Each order on every character 8 times, targets drawn from `r`: every update's time (us).
  std::vector<double> rate_solve_us;  // the strikes' playback rates, found between updates
  // Every update's time (us). Each strike is recorded `passes` times: the same inputs give the
  // same frames (checked: the same motion), so frame k does the same work in every pass, and its
  // least time is what the update costs; a frame the machine interrupted (a virtual machine's
  // timer and interrupt work, ~40 us at random) is slow in one pass only. `one_pass` gets the
  // first pass's times as they came.
  const auto time_strikes = [&](const FighterConfig& fighter, std::mt19937& r, int& strikes, int passes,
                                std::vector<double>* one_pass) {
    std::vector<double> us;
    for (int rep = 0; rep < 8; ++rep) {
      for (const Rig& rig : rigs) {
        for (auto kind : kinds) {
          const double h = rig.morphology.height_m;
          const bool kick = kind >= kumite::OrderKind::kick_left;
          const Eigen::Vector3d target(0.15 * u(r), (kick ? 0.6 : 0.9) * h, 0.38 * h);
          const StrikeRecording rec = record_strike(db, rig, kind, target, fighter);
          std::vector<double> least = rec.update_us;
          if (one_pass) one_pass->insert(one_pass->end(), rec.update_us.begin(), rec.update_us.end());
          for (int p = 1; p < passes; ++p) {
            const StrikeRecording again = record_strike(db, rig, kind, target, fighter);
            const auto same_rotations = [&] {
              const auto& x = again.motion.local_rotations;
              const auto& y = rec.motion.local_rotations;
              if (x.size() != y.size()) return false;
              for (std::size_t k = 0; k < x.size(); ++k)
                if (x[k].coeffs() != y[k].coeffs()) return false;
              return true;
            };
            if (again.update_us.size() != least.size() || again.motion.root_positions != rec.motion.root_positions ||
                !same_rotations())
              throw kumite::Error("bench", "not_deterministic", fmt::format("bench: {} {} played twice gave two motions (the fighter is not deterministic)",
                                              rig.name, kumite::to_string(kind)));
            for (std::size_t k = 0; k < least.size(); ++k) least[k] = std::min(least[k], again.update_us[k]);
          }
          us.insert(us.end(), least.begin(), least.end());
          if (rec.rate_solve_us > 0) rate_solve_us.push_back(rec.rate_solve_us);
          ++strikes;
        }
      }
    }
    return us;
  };
  int strikes = 0;
  std::vector<double> one_pass_us;
  const std::vector<double> adapt_us =
      a.skip_adaptation ? std::vector<double>{} : time_strikes(g_fighter, rng, strikes, a.adaptation_passes, &one_pass_us);
  j["adaptation_us_per_frame"] = stats_json(adapt_us);
  j["adaptation_passes"] = a.adaptation_passes;
  j["adaptation_us_per_frame_one_pass"] = stats_json(one_pass_us);
  j["adaptation_strikes"] = strikes;
  if (!a.skip_adaptation) j["machine_noise_us"] = machine_noise_json(adapt_us);
  // Finding each strike's playback rate (StrikeRateSolver): off the frame (the Fighter's worker
  // thread; record_strike between updates), so not in adaptation_us_per_frame.
  if (!rate_solve_us.empty()) j["strike_rate_solve_us"] = stats_json(rate_solve_us);
  if (!a.skip_adaptation && g_fighter.behaviour.min_strike_rate >= 1) {
    // The same strikes with the playback rate on (BehaviourTunables::min_strike_rate), as it
    // was turned on before it was on by default.
    FighterConfig with_rate = g_fighter;
    with_rate.behaviour.min_strike_rate = 0.6;
    with_rate.behaviour.blend_time_s = 0.25;
    std::mt19937 rng_rate(7);
    int rate_strikes = 0;
    j["adaptation_us_per_frame_strike_rate"] = stats_json(time_strikes(with_rate, rng_rate, rate_strikes, a.adaptation_passes, nullptr));
  }

  // 4. Motion quality (what the eye sees; `kumite-motion quality` for the per-strike detail).
  if (a.quality_targets > 0) {
    t0 = now_s();
    QualityTotals totals;
    measure_grid(db, rigs, a.quality_targets, "", totals);
    j["motion_quality"] = totals.json();
    j["motion_quality"]["targets_per_order"] = a.quality_targets;
    j["motion_quality"]["seconds"] = now_s() - t0;
  }
  if (a.bout_seconds > 0) {
    t0 = now_s();
    const BoutResult bout = run_bout_scenario(db, rigs, a.bout_seconds, "");
    j["motion_quality"]["bout"] = bout.report["summary"];
    j["motion_quality"]["bout"]["seconds_simulated"] = a.bout_seconds;
    j["motion_quality"]["bout"]["seconds"] = now_s() - t0;
  }
  fmt::print("{}\n", j.dump(2));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-motion: motion content tools (annotation, characters, database, strikes, bench)"};
  app.require_subcommand(1);
  std::string tunables_file;
  app.add_option("--tunables", tunables_file,
                 "installation file (config/demo.toml) whose [fighter.behaviour], [fighter.behaviour.feet] and "
                 "[fighter.retrieval] the fighter plays with (strike, quality, bout, bench, tunables)")
      ->check(CLI::ExistingFile);
  auto* tunables_cmd = app.add_subcommand(
      "tunables", "Print the fighter's tunables as TOML, each with its unit and range (the defaults, or --tunables')");
  AnnotateArgs annotate_args;
  add_annotate(app, annotate_args);
  MakeCharactersArgs make_characters_args;
  add_make_characters(app, make_characters_args);
  BuildArgs build_args;
  add_build(app, build_args);
  ResampleArgs resample_args;
  add_resample(app, resample_args);
  StrikeArgs strike_args;
  add_strike(app, strike_args);
  BenchArgs bench_args;
  add_bench(app, bench_args);
  QualityArgs quality_args;
  add_quality(app, quality_args);
  BoutArgs bout_args;
  add_bout(app, bout_args);
  SparArgs spar_args;
  add_spar(app, spar_args);
  HitsArgs hits_args;
  add_hits(app, hits_args);
  CLI11_PARSE(app, argc, argv);
  try {
    if (!tunables_file.empty()) read_fighter_tunables(tunables_file, g_fighter.behaviour, g_fighter.retrieval);
    if (app.got_subcommand(tunables_cmd)) {
      fmt::print("{}", format_fighter_tunables(g_fighter.behaviour, g_fighter.retrieval));
      return 0;
    }
    if (app.got_subcommand("annotate")) return run_annotate(annotate_args);
    if (app.got_subcommand("make-characters")) return run_make_characters(make_characters_args);
    if (app.got_subcommand("build")) return run_build(build_args);
    if (app.got_subcommand("resample")) return run_resample(resample_args);
    if (app.got_subcommand("strike")) return run_strike(strike_args);
    if (app.got_subcommand("bench")) return run_bench(bench_args);
    if (app.got_subcommand("quality")) return run_quality(quality_args);
    if (app.got_subcommand("bout")) return run_bout(bout_args);
    if (app.got_subcommand("spar")) return run_spar(spar_args);
    if (app.got_subcommand("hits")) return run_hits(hits_args);
  } catch (const kumite::Error& e) {
    std::fprintf(stderr, "kumite-motion: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-motion: %s\n", e.what());
    return 1;
  }
  return 0;
}
