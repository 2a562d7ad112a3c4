// kumite-motion: the offline motion-content tool. One function per sub-command:
//   annotate <clips...> --out motions.toml   propose annotations for people to review
//   make-characters [--catalog characters.toml] [--base 135_08.bvh] [--check]
//                                            generate the shipped character skeletons
// Errors: one line on stderr, exit 1.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/annotation.hpp"
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
    std::string rel = fs::relative(fs::absolute(file), out.parent_path()).generic_string();
    ClipAnnotation c = propose_annotations(clip, rel);
    c.mirror = !a.no_mirror;
    fmt::print("{}: {} frames @ {:.0f} fps, dialect {}:\n", file, clip.frame_count, clip.frame_rate_hz(),
               clip.skeleton.dialect);
    for (const auto& m : c.motions) {
      fmt::print("  {:<28} {:<6} [{:5}, {:5}]", m.name, to_string(m.semantics), m.first_frame, m.last_frame);
      if (m.hit_frame) {
        fmt::print("  {} hit f{} ({:.2f} s), peak {:.1f} m/s, extension {:.2f}", to_string(*m.hit_segment),
                   *m.hit_frame, *m.hit_frame * clip.frame_time_s, m.peak_speed_mps, m.extension);
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kumite-motion: motion content tools (annotation, characters)"};
  app.require_subcommand(1);
  AnnotateArgs annotate_args;
  add_annotate(app, annotate_args);
  MakeCharactersArgs make_characters_args;
  add_make_characters(app, make_characters_args);
  CLI11_PARSE(app, argc, argv);
  try {
    if (app.got_subcommand("annotate")) return run_annotate(annotate_args);
    if (app.got_subcommand("make-characters")) return run_make_characters(make_characters_args);
  } catch (const kumite::Error& e) {
    std::fprintf(stderr, "kumite-motion: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kumite-motion: %s\n", e.what());
    return 1;
  }
  return 0;
}
