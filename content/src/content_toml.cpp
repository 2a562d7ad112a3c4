// Every TOML file content/ reads (dialect maps, motions.toml, characters.toml) goes through
// this one translation unit: the only place in the library that includes toml++.
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"
#include "kumite/content/annotation.hpp"
#include "kumite/content/canonical.hpp"
#include "kumite/content/character.hpp"
#include "kumite/content/planner.hpp"
#include "kumite/content/tunables.hpp"

namespace kumite::content {

namespace {

/// The project's strict table reader (kumite/common/toml_reader.hpp), named as content's
/// readers always named it: Table(table, file, dotted prefix, component).
class Table : public TomlTable {
 public:
  Table(const toml::table& t, std::string_view file, std::string prefix, std::string_view component)
      : TomlTable(t, component, file, std::move(prefix)) {}
};

toml::table parse_toml(std::string_view text, std::string_view source, std::string_view component) {
  return kumite::parse_toml(text, source, component);
}

std::string read_text(const std::filesystem::path& path, std::string_view component) {
  return read_text_file(path, component);
}

}  // namespace

// ---- Dialect maps ---------------------------------------------------------------------------

Dialect parse_dialect_toml(std::string_view text, std::string_view source) {
  const toml::table doc = parse_toml(text, source, "dialect");
  const Table top(doc, source, "", "dialect");
  top.only({"name", "description", "joints"});
  Dialect d;
  d.name = top.string("name");
  if (d.name.empty()) top.fail("value", "name", "must not be empty");
  d.description = top.opt_string("description").value_or("");
  d.source = std::string(source);
  const auto joints_table = top.opt_table("joints");
  if (!joints_table) top.fail("missing_key", "joints", "is required ([joints] canonical = \"JointName\")");
  const toml::table* joints = &joints_table->raw();
  const Table jt(*joints, source, "joints", "dialect");
  std::set<std::string> used;
  for (const auto& [k, v] : *joints) {
    const auto c = canonical_joint_from_string(k.str());
    if (!c) {
      jt.fail_at(v, "unknown_joint", k.str(),
              "not a canonical joint (pelvis, spine, chest, neck, head, l_/r_ clavicle, shoulder, elbow, wrist, "
              "hip, knee, ankle, toe)");
    }
    const std::string name = jt.string(k.str());
    if (name.empty()) jt.fail("value", k.str(), "must not be empty");
    if (!used.insert(name).second) jt.fail("duplicate", k.str(), fmt::format("joint '{}' is mapped twice", name));
    d.joints[static_cast<std::size_t>(*c)] = name;
  }
  return d;
}

Dialect read_dialect_toml(const std::filesystem::path& path) {
  return parse_dialect_toml(read_text(path, "dialect"), path.string());
}

// ---- motions.toml ---------------------------------------------------------------------------

namespace {

MotionAnnotation parse_motion(const toml::table& t, std::string_view source, const std::string& prefix,
                              std::set<std::string>& names) {
  const Table m(t, source, prefix, "annotation");
  m.only({"name", "semantics", "frames", "hit_segment", "hit_frame", "height", "note", "peak_speed_mps",
          "extension", "repair_frames", "forearm", "intercept_frames"});
  MotionAnnotation a;
  a.line = m.line();
  a.name = m.string("name");
  if (a.name.empty()) m.fail("value", "name", "must not be empty");
  if (!names.insert(a.name).second) m.fail("duplicate", "name", fmt::format("motion name '{}' is used twice", a.name));
  const std::string sem = m.string("semantics");
  const auto semantics = semantics_from_string(sem);
  if (!semantics) m.fail("value", "semantics", fmt::format("unknown semantics '{}' (punch, kick, block, walk, rest, other)", sem));
  a.semantics = *semantics;
  const toml::array* frames = m.opt_array("frames");
  if (!frames) m.fail("missing_key", "frames", "is required: [first, last]");
  if (frames->size() != 2 || !(*frames)[0].is_integer() || !(*frames)[1].is_integer()) {
    m.fail("type", "frames", "must be [first, last] (two integers)");
  }
  const int64_t first = *(*frames)[0].value<int64_t>(), last = *(*frames)[1].value<int64_t>();
  if (first < 0 || last < first || last > 100'000'000) {
    m.fail("range", "frames", fmt::format("[{}, {}] must satisfy 0 <= first <= last", first, last));
  }
  a.first_frame = static_cast<int>(first);
  a.last_frame = static_cast<int>(last);
  if (auto seg = m.opt_string("hit_segment")) {
    const auto h = hit_segment_from_string(*seg);
    if (!h) m.fail("value", "hit_segment", fmt::format("unknown segment '{}' (left_hand, right_hand, left_foot, right_foot)", *seg));
    a.hit_segment = *h;
  }
  if (auto hf = m.opt_integer("hit_frame")) {
    if (*hf < a.first_frame || *hf > a.last_frame) {
      m.fail("range", "hit_frame", fmt::format("{} is outside frames [{}, {}]", *hf, a.first_frame, a.last_frame));
    }
    a.hit_frame = static_cast<int>(*hf);
  }
  if (auto h = m.opt_string("height")) {
    const auto height = strike_height_from_string(*h);
    if (!height) m.fail("value", "height", fmt::format("unknown height '{}' (low, mid, high)", *h));
    a.height = *height;
  }
  if (auto f = m.opt_string("forearm")) {
    if (a.semantics != Semantics::block) m.fail("value", "forearm", fmt::format("only blocks have one, not {}", sem));
    const auto forearm = forearm_from_string(*f);
    if (!forearm) m.fail("value", "forearm", fmt::format("unknown forearm '{}' (left, right)", *f));
    a.forearm = *forearm;
  }
  if (const toml::array* w = m.opt_array("intercept_frames")) {
    if (a.semantics != Semantics::block) m.fail("value", "intercept_frames", fmt::format("only blocks have them, not {}", sem));
    if (w->size() != 2 || !(*w)[0].is_integer() || !(*w)[1].is_integer()) m.fail("type", "intercept_frames", "must be [first, last] (two integers)");
    const int64_t wa = *(*w)[0].value<int64_t>(), wb = *(*w)[1].value<int64_t>();
    if (wa < a.first_frame || wb > a.last_frame || wb < wa) {
      m.fail("range", "intercept_frames",
             fmt::format("[{}, {}] must lie inside frames [{}, {}], first <= last", wa, wb, a.first_frame, a.last_frame));
    }
    a.intercept_frames = std::array<int, 2>{static_cast<int>(wa), static_cast<int>(wb)};
  }
  if (a.semantics == Semantics::block && (a.forearm || a.intercept_frames || a.height) &&
      !(a.forearm && a.intercept_frames && a.height)) {
    const std::string_view missing = !a.forearm ? "forearm" : !a.intercept_frames ? "intercept_frames" : "height";
    m.fail("missing_key", missing,
           "is required for a reviewed block (forearm, intercept_frames and height together; none: an unreviewed "
           "block, left out of the database)");
  }
  if (is_strike(a.semantics)) {
    if (!a.hit_segment) m.fail("missing_key", "hit_segment", fmt::format("is required for a {}", sem));
    if (!a.hit_frame) m.fail("missing_key", "hit_frame", fmt::format("is required for a {}", sem));
    if (a.semantics == Semantics::punch && !is_hand(*a.hit_segment)) m.fail("value", "hit_segment", "a punch hits with a hand");
    if (a.semantics == Semantics::kick && is_hand(*a.hit_segment)) m.fail("value", "hit_segment", "a kick hits with a foot");
  } else {
    if (a.hit_segment) m.fail("value", "hit_segment", fmt::format("only strikes (punch, kick) have one, not {}", sem));
    if (a.hit_frame) m.fail("value", "hit_frame", fmt::format("only strikes (punch, kick) have one, not {}", sem));
    if (a.height && a.semantics != Semantics::block)
      m.fail("value", "height", fmt::format("only strikes (punch, kick) and blocks have one, not {}", sem));
  }
  a.note = m.opt_string("note").value_or("");
  // Informational, but read like every number: a limb's end faster than 100 m/s or stretched to
  // twice its length is a damaged file (1e281 read, written back as a 282-digit literal the
  // reader then refused: found by fuzz_motions).
  a.peak_speed_mps = m.opt_number("peak_speed_mps", {0, 100, "m/s"}).value_or(0);
  a.extension = m.opt_number("extension", {0, 2, ""}).value_or(0);
  if (const toml::array* r = m.opt_array("repair_frames")) {
    if (r->size() != 2 || !(*r)[0].is_integer() || !(*r)[1].is_integer()) m.fail("type", "repair_frames", "must be [first, last] (two integers)");
    const int64_t ra = *(*r)[0].value<int64_t>(), rb = *(*r)[1].value<int64_t>();
    if (ra <= a.first_frame || rb >= a.last_frame || rb < ra) {
      m.fail("range", "repair_frames",
             fmt::format("[{}, {}] must lie inside frames [{}, {}], not on their first or last (the frames around it are interpolated)",
                         ra, rb, a.first_frame, a.last_frame));
    }
    if (rb - ra + 1 > kMaxRepairFrames) {
      m.fail("range", "repair_frames", fmt::format("[{}, {}] rebuilds {} frames: at most {} (a glitch, not a motion)", ra, rb, rb - ra + 1, kMaxRepairFrames));
    }
    a.repair_frames = std::array<int, 2>{static_cast<int>(ra), static_cast<int>(rb)};
  }
  return a;
}

}  // namespace

AnnotationSet parse_annotations(std::string_view text, std::string_view source) {
  const toml::table doc = parse_toml(text, source, "annotation");
  const Table top(doc, source, "", "annotation");
  top.only({"version", "clip"});
  AnnotationSet set;
  set.source = std::string(source);
  set.version = static_cast<int>(top.integer("version"));
  if (set.version != kAnnotationVersion) {
    top.fail("version", "version", fmt::format("version {} is not supported (expected {})", set.version, kAnnotationVersion));
  }
  const toml::array* clips = top.opt_array("clip");
  if (!clips) return set;
  std::set<std::string> clip_names, motion_names;
  for (std::size_t i = 0; i < clips->size(); ++i) {
    const std::string prefix = fmt::format("clip[{}]", i);
    const toml::node& node = (*clips)[i];
    if (!node.is_table()) throw file_error("annotation", "type", source, static_cast<int>(node.source().begin.line), prefix, "must be a table ([[clip]])");
    const Table c(*node.as_table(), source, prefix, "annotation");
    c.only({"file", "name", "mirror", "unit_m", "motion"});
    ClipAnnotation clip;
    clip.line = c.line();
    clip.file = c.string("file");
    if (clip.file.empty()) c.fail("value", "file", "must not be empty");
    clip.name = c.opt_string("name").value_or(std::filesystem::path(clip.file).stem().string());
    if (clip.name.empty()) c.fail("value", "name", "must not be empty");
    if (!clip_names.insert(clip.name).second) c.fail("duplicate", "name", fmt::format("clip name '{}' is used twice", clip.name));
    if (const toml::node* mirror = node.as_table()->get("mirror")) {
      if (!mirror->is_boolean()) c.fail("type", "mirror", "must be true or false");
      clip.mirror = mirror->as_boolean()->get();
    }
    clip.unit_m = c.opt_number("unit_m", {kClipUnitRangeM[0], kClipUnitRangeM[1], "m per file unit"});
    if (const toml::array* motions = c.opt_array("motion")) {
      for (std::size_t j = 0; j < motions->size(); ++j) {
        const std::string mp = fmt::format("{}.motion[{}]", prefix, j);
        const toml::node& mn = (*motions)[j];
        if (!mn.is_table()) throw file_error("annotation", "type", source, static_cast<int>(mn.source().begin.line), mp, "must be a table ([[clip.motion]])");
        clip.motions.push_back(parse_motion(*mn.as_table(), source, mp, motion_names));
      }
    }
    set.clips.push_back(std::move(clip));
  }
  return set;
}

AnnotationSet read_annotations(const std::filesystem::path& path) {
  return parse_annotations(read_text(path, "annotation"), path.string());
}

// ---- characters.toml -------------------------------------------------------------------------

namespace {

CharacterSpec parse_generate(const toml::table& t, std::string_view source, const std::string& prefix) {
  const Table g(t, source, prefix, "character");
  g.only({"stature_m", "dialect", "torso", "neck_head", "shoulder_width", "upper_arm", "forearm", "hand",
          "pelvis_width", "thigh", "shin", "foot"});
  CharacterSpec spec;
  spec.stature_m = g.number("stature_m");
  if (spec.stature_m < 0.3 || spec.stature_m > 3.0) g.fail("range", "stature_m", "must be 0.3..3 m");
  spec.dialect = g.opt_string("dialect").value_or("cmu");
  if (spec.dialect != "cmu" && spec.dialect != "motionbuilder") {
    g.fail("value", "dialect", fmt::format("unknown dialect '{}' (cmu, motionbuilder)", spec.dialect));
  }
  auto factor = [&](std::string_view key, double& out) {
    if (auto v = g.opt_number(key)) {
      if (*v < 0.3 || *v > 3.0) g.fail("range", key, fmt::format("scale {} must be 0.3..3", *v));
      out = *v;
    }
  };
  SegmentScales& sc = spec.scales;
  factor("torso", sc.torso);
  factor("neck_head", sc.neck_head);
  factor("shoulder_width", sc.shoulder_width);
  factor("upper_arm", sc.upper_arm);
  factor("forearm", sc.forearm);
  factor("hand", sc.hand);
  factor("pelvis_width", sc.pelvis_width);
  factor("thigh", sc.thigh);
  factor("shin", sc.shin);
  factor("foot", sc.foot);
  return spec;
}

}  // namespace

CharacterCatalog parse_characters(std::string_view text, std::string_view source) {
  const toml::table doc = parse_toml(text, source, "character");
  const Table top(doc, source, "", "character");
  top.only({"version", "character"});
  const int64_t version = top.integer("version");
  if (version != kCharacterCatalogVersion) {
    top.fail("version", "version", fmt::format("version {} is not supported (expected {})", version, kCharacterCatalogVersion));
  }
  CharacterCatalog cat;
  cat.source = std::string(source);
  const toml::array* chars = top.opt_array("character");
  if (!chars || chars->empty()) top.fail("missing_key", "character", "at least one [[character]] is required");
  std::set<std::string> names;
  for (std::size_t i = 0; i < chars->size(); ++i) {
    const std::string prefix = fmt::format("character[{}]", i);
    const toml::node& node = (*chars)[i];
    if (!node.is_table()) throw file_error("character", "type", source, static_cast<int>(node.source().begin.line), prefix, "must be a table ([[character]])");
    const Table c(*node.as_table(), source, prefix, "character");
    c.only({"name", "display_name", "file", "notes", "generate"});
    CharacterEntry e;
    e.line = c.line();
    e.name = c.string("name");
    if (e.name.empty()) c.fail("value", "name", "must not be empty");
    if (!names.insert(e.name).second) c.fail("duplicate", "name", fmt::format("character '{}' is listed twice", e.name));
    e.display_name = c.opt_string("display_name").value_or(e.name);
    e.file = c.string("file");
    if (e.file.empty()) c.fail("value", "file", "must not be empty");
    e.notes = c.opt_string("notes").value_or("");
    if (const auto g = c.opt_table("generate")) e.generate = parse_generate(g->raw(), source, prefix + ".generate");
    cat.characters.push_back(std::move(e));
  }
  return cat;
}

CharacterCatalog read_characters(const std::filesystem::path& path) {
  return parse_characters(read_text(path, "character"), path.string());
}

// ---- [fighter.behaviour], [fighter.behaviour.feet], [fighter.retrieval] ----------------------

void parse_fighter_tunables(std::string_view text, std::string_view file, BehaviourTunables& b,
                            RetrievalTunables& r) {
  const toml::table doc = parse_toml(text, file, "config");
  const TomlTable root(doc, "config", file);
  const auto fighter = root.opt_table("fighter");
  if (!fighter) return validate(b, r);
  std::map<std::string, int> lines;  // key under [fighter] -> line, for contradictions
  const auto read_table = [&](const TomlTable& t, std::string_view name, std::vector<std::string_view> allowed) {
    for (const TunableKey& k : fighter_tunable_keys()) {
      if (k.table == name) allowed.push_back(k.key);
    }
    t.only(allowed);
    for (const TunableKey& k : fighter_tunable_keys()) {
      if (k.table != name || !t.has(k.key)) continue;
      double& v = k.behaviour ? b.*k.behaviour : k.feet ? b.feet.*k.feet : r.*k.retrieval;
      t.read(k.key, v, {k.min, k.max, k.unit});
      lines[std::string(name) + "." + std::string(k.key)] = t.line(k.key);
    }
  };
  if (const auto beh = fighter->opt_table("behaviour")) {
    read_table(*beh, "behaviour", {"feet"});
    if (const auto feet = beh->opt_table("feet")) read_table(*feet, "behaviour.feet", {});
  }
  if (const auto ret = fighter->opt_table("retrieval")) read_table(*ret, "retrieval", {});
  if (const auto p = tunables_problem(b, r)) {
    const auto at = lines.find(p->key);
    throw file_error("config", p->code, file, at != lines.end() ? at->second : fighter->line(),
                     "fighter." + p->key, p->message);
  }
}

// ---- [fighter.planner] ---------------------------------------------------------------------

void parse_planner_tunables(std::string_view text, std::string_view file, PlannerTunables& p, std::uint64_t& seed,
                            double follow_tolerance_m) {
  const toml::table doc = parse_toml(text, file, "config");
  const TomlTable root(doc, "config", file);
  const auto fighter = root.opt_table("fighter");
  if (!fighter) return;
  const auto t = fighter->opt_table("planner");
  if (!t) return;
  t->only({"mode", "preset", "seed", "fighting_distance_m", "engage_tolerance_m", "stance_step_min_m", "follow_arc_deg", "attack_rate_per_s", "counter_probability",
           "reaction_time_s", "counter_deadline_s", "kick_share", "abort_probability", "block", "block_max_rate", "threat_min_speed_mps",
           "threat_min_closing_mps", "threat_horizon_s", "threat_aim_radius_m", "threat_velocity_window_s", "threat_min_extension", "threat_two_hand_mirror", "hit_min_speed_mps",
           "hit_full_speed_mps", "hit_head_max_deg", "hit_trunk_max_deg", "hit_shoulder_max_deg", "hit_stiffness_rad_s",
           "hit_damping_ratio", "hit_step_back_m", "hit_step_back_share"});
  // A preset first, then each key written beside it.
  if (const auto preset = t->opt_string("preset")) {
    const auto found = planner_preset(*preset);
    if (!found) t->fail("value", "preset", "'" + *preset + "': one of aggressive_unskilled, defensive_skilled");
    p = *found;
  }
  if (const auto mode = t->opt_string("mode")) {
    if (*mode == "orders") p.mode = PlannerMode::orders;
    else if (*mode == "spar") p.mode = PlannerMode::spar;
    else t->fail("value", "mode", "'" + *mode + "': orders or spar");
  }
  if (const auto s = t->opt_integer("seed", 0)) seed = static_cast<std::uint64_t>(*s);
  t->read("fighting_distance_m", p.fighting_distance_m, {0.3, 3, "m"});
  t->read("engage_tolerance_m", p.engage_tolerance_m, {0, 2, "m"});
  // (checked against follow_tolerance_m where written: the default, 0.5, is raised to a larger
  // follow_tolerance_m by the behaviour, Behaviour::stance_step_min_m)
  if (t->read("stance_step_min_m", p.stance_step_min_m, {0, 2, "m"}) && p.stance_step_min_m > 0 &&
      p.stance_step_min_m < follow_tolerance_m)
    t->fail("range", "stance_step_min_m",
            fmt::format("must be 0 (no stance steps) or at least [fighter.behaviour] follow_tolerance_m ({} m)", follow_tolerance_m));
  t->read("follow_arc_deg", p.follow_arc_deg, {10, 180, "deg"});
  t->read("attack_rate_per_s", p.attack_rate_per_s, {0, 10, "1/s"});
  t->read("counter_probability", p.counter_probability, {0, 1, ""});
  t->read("reaction_time_s", p.reaction_time_s, {0, 5, "s"});
  t->read("counter_deadline_s", p.counter_deadline_s, {0, 10, "s"});
  t->read("kick_share", p.kick_share, {0, 1, ""});
  t->read("abort_probability", p.abort_probability, {0, 1, ""});
  if (const auto b = t->opt_boolean("block")) p.block = *b;
  t->read("block_max_rate", p.block_max_rate, {1, 4, ""});
  t->read("threat_min_speed_mps", p.threat.min_speed_mps, {0.1, 50, "m/s"});
  t->read("threat_min_closing_mps", p.threat.min_closing_mps, {0, 50, "m/s"});
  t->read("threat_horizon_s", p.threat.horizon_s, {0.05, 2, "s"});
  t->read("threat_aim_radius_m", p.threat.aim_radius_m, {0.05, 1, "m"});
  t->read("threat_velocity_window_s", p.threat.velocity_window_s, {0.005, 0.5, "s"});
  t->read("threat_min_extension", p.threat.min_extension, {0, 1, ""});
  t->read("threat_two_hand_mirror", p.threat.two_hand_mirror, {0, 1, ""});
  t->read("hit_min_speed_mps", p.hit_min_speed_mps, {0.1, 20, "m/s"});
  t->read("hit_full_speed_mps", p.hit_full_speed_mps, {0.2, 50, "m/s"});
  t->read("hit_head_max_deg", p.hit_head_max_deg, {0, 45, "deg"});
  t->read("hit_trunk_max_deg", p.hit_trunk_max_deg, {0, 30, "deg"});
  t->read("hit_shoulder_max_deg", p.hit_shoulder_max_deg, {0, 45, "deg"});
  t->read("hit_stiffness_rad_s", p.hit_stiffness_rad_s, {4, 40, "rad/s"});
  t->read("hit_damping_ratio", p.hit_damping_ratio, {0.4, 1, ""});
  t->read("hit_step_back_m", p.hit_step_back_m, {0, 0.8, "m"});
  t->read("hit_step_back_share", p.hit_step_back_share, {0, 1, ""});
  if (!(p.hit_full_speed_mps > p.hit_min_speed_mps))
    t->fail("value", t->has("hit_full_speed_mps") ? "hit_full_speed_mps" : "hit_min_speed_mps",
            "hit_full_speed_mps must be above hit_min_speed_mps");
}

void read_fighter_tunables(const std::filesystem::path& file, BehaviourTunables& b, RetrievalTunables& r) {
  parse_fighter_tunables(read_text(file, "config"), file.string(), b, r);
}

}  // namespace kumite::content
