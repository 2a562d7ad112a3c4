// kumite-motion: the offline motion-content tool. One function per sub-command:
//   annotate <clips...> --out motions.toml   propose annotations for people to review
//   make-characters [--catalog characters.toml] [--base 135_08.bvh] [--check]
//                                            generate the shipped character skeletons
//   build --annotations motions.toml --out fighter.kdb
//                                            the fighter's motion database
//   strike --db fighter.kdb --character <name|file.bvh> --order punch_right --target X,Y,Z
//          --out strike.bvh --report strike.json
//                                            one adapted strike, written as BVH + JSON report
//   bench [--db fighter.kdb]                 retrieval and adaptation timings as JSON
// Errors: one line on stderr, exit 1.
#include <algorithm>
#include <chrono>
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
#include "kumite/content/proportions.hpp"

namespace fs = std::filesystem;
using namespace kumite::content;

namespace {

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
  int strikes = 0, rest = 0;
  for (const auto& s : db.segments) {
    strikes += s.kind == SegmentKind::strike;
    rest += s.kind == SegmentKind::rest;
  }
  fmt::print("wrote {}: {} segments ({} strikes, {} rest, mirrored copies included), {} strike candidates in {} "
             "clusters; actor {} (leg length {:.3f} m); {:.1f} s\n",
             a.out, db.segments.size(), strikes, rest, db.index.size, db.index.clusters.size(), db.actor_name,
             db.actor.leg_length_m, now_s() - t0);
  return 0;
}

// ---- strike --------------------------------------------------------------------------------

struct StrikeArgs {
  std::string db, character, order, target, out, report;
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
  auto db = std::make_shared<const Database>(load_database(a.db));
  const Rig rig = load_character_rig(a.character);
  const StrikeRecording rec = record_strike(db, rig, order->kind, target);
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
  j["reach_error_m"] = rec.strike.contact_distance_m;
  j["hit"] = rec.strike.hit;
  j["hit_radius_m"] = FighterConfig{}.hit_radius_m;
  j["retrieval_us"] = rec.retrieval_us;
  j["retrieval_cost"] = rec.strike.plan.choice.cost;
  j["target_in_box"] = rec.strike.plan.choice.target_in_box;
  const auto us = rec.update_us;
  j["adaptation_us"] = {{"mean", mean(us)}, {"p99", percentile(us, 99)}, {"max", percentile(us, 100)}};
  j["foot_slide_mm"] = rec.max_foot_slide_m * 1000;
  j["bvh_unit_m"] = motion.unit_m;
  j["events"] = rec.events;
  kumite::write_file_atomically(a.report, j.dump(2) + "\n");
  fmt::print("{} {} on {}: {} from {} f{}{}, contact at frame {} of {}: {} (reach error {:.2f} mm{}); wrote {} and {}\n",
             a.order, a.target, rig.name, rec.segment_name, rec.source_clip, rec.source_start_frame,
             rec.mirrored ? " (mirrored)" : "", rec.contact_frame, motion.frame_count, rec.strike.hit ? "hit" : "miss",
             rec.strike.contact_distance_m * 1000, rec.strike.contact_reached ? "" : ", target out of reach", a.out,
             a.report);
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
  const StrikePlanner planner(db);
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
  std::vector<double> adapt_us;
  std::uniform_real_distribution<double> u(-1, 1);
  const kumite::OrderKind kinds[4] = {kumite::OrderKind::punch_right, kumite::OrderKind::punch_left,
                                      kumite::OrderKind::kick_right, kumite::OrderKind::kick_left};
  int strikes = 0;
  for (int rep = 0; rep < (a.skip_adaptation ? 0 : 8); ++rep) {
    for (const Rig& rig : rigs) {
      for (auto kind : kinds) {
        const double h = rig.morphology.height_m;
        const bool kick = kind >= kumite::OrderKind::kick_left;
        const Eigen::Vector3d target(0.15 * u(rng), (kick ? 0.6 : 0.9) * h, 0.38 * h);
        const StrikeRecording rec = record_strike(db, rig, kind, target);
        adapt_us.insert(adapt_us.end(), rec.update_us.begin(), rec.update_us.end());
        ++strikes;
      }
    }
  }
  j["adaptation_us_per_frame"] = stats_json(adapt_us);
  j["adaptation_strikes"] = strikes;
  fmt::print("{}\n", j.dump(2));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-motion: motion content tools (annotation, characters, database, strikes, bench)"};
  app.require_subcommand(1);
  AnnotateArgs annotate_args;
  add_annotate(app, annotate_args);
  MakeCharactersArgs make_characters_args;
  add_make_characters(app, make_characters_args);
  BuildArgs build_args;
  add_build(app, build_args);
  StrikeArgs strike_args;
  add_strike(app, strike_args);
  BenchArgs bench_args;
  add_bench(app, bench_args);
  CLI11_PARSE(app, argc, argv);
  try {
    if (app.got_subcommand("annotate")) return run_annotate(annotate_args);
    if (app.got_subcommand("make-characters")) return run_make_characters(make_characters_args);
    if (app.got_subcommand("build")) return run_build(build_args);
    if (app.got_subcommand("strike")) return run_strike(strike_args);
    if (app.got_subcommand("bench")) return run_bench(bench_args);
  } catch (const kumite::Error& e) {
    std::fprintf(stderr, "kumite-motion: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-motion: %s\n", e.what());
    return 1;
  }
  return 0;
}
