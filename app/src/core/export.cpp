#include "kumite/app/export.hpp"

#include <cctype>
#include <cmath>
#include <fstream>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "json_reader.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"

namespace kumite::app {

namespace {
using nlohmann::json;

}  // namespace

std::filesystem::path run_bvh_path(const std::filesystem::path& bvh, int index, const std::string& character_name) {
  std::string name;
  for (const char c : character_name) name += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' ? c : '_';
  auto out = bvh;
  out.replace_filename(fmt::format("{}.{:02}-{}{}", bvh.stem().string(), index + 1, name, bvh.extension().string()));
  return out;
}

ExportReport export_log(const InstallationConfig& config, const ExportOptions& opt) {
  if (!std::isfinite(opt.from_s) || !std::isfinite(opt.to_s) || opt.to_s < opt.from_s)
    throw Error("cli", "range", fmt::format("--from {} --to {}: expected finite times with from <= to", opt.from_s, opt.to_s));
  std::ifstream in(opt.log, std::ios::binary);
  if (!in) throw Error("io", "open", fmt::format("{}: cannot read", opt.log.string()));
  JsonLineReader r{"export", "log", opt.log.string(), 0};
  ExportReport rep;

  // The fighter's runs: one per stretch of frames with one character (a switch starts the next).
  struct Run {
    content::Clip clip;
    ExportRun info;
  };
  std::vector<Run> runs;
  std::string csv = "frame,time_s,x_m,y_m,z_m,qw,qx,qy,qz,live\n";
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(std::move(l));
  const bool ends_with_newline = [&] {
    in.clear();
    in.seekg(0, std::ios::end);
    const auto size = static_cast<long long>(in.tellg());
    if (size <= 0) return true;
    in.seekg(size - 1);
    return in.get() == '\n';
  }();
  for (std::size_t i = 0; i < lines.size(); ++i) {
    r.line = static_cast<int>(i) + 1;
    json j = json::parse(lines[i], nullptr, false);
    if (j.is_discarded()) {
      if (i + 1 == lines.size() && !ends_with_newline) {  // killed mid-line: the frames before stand
        rep.truncated_last_line = true;
        spdlog::warn("{}:{}: the last line is cut short (a run killed while writing it): left out", r.file, r.line);
        break;
      }
      r.fail("", "not valid JSON (or not an object)");
    }
    const double t = r.num(r.at(j, "time_s", "time_s"), "time_s");
    if (t < opt.from_s) continue;
    if (t > opt.to_s) break;
    const int frame = static_cast<int>(r.num(r.at(j, "frame", "frame"), "frame"));
    if (rep.frames == 0) {
      rep.first_frame = frame;
      rep.first_time_s = t;
    }
    ++rep.frames;
    rep.last_frame = frame;
    rep.last_time_s = t;
    if (opt.head_csv) {
      const json& head = r.at(j, "head", "head");
      const auto p = r.nums<3>(r.at(head, "position", "head.position"), "head.position");
      const auto q = r.nums<4>(r.at(head, "quaternion", "head.quaternion"), "head.quaternion");
      const bool live = head.value("live", false);
      csv += fmt::format("{},{:.6f},{:.6f},{:.6f},{:.6f},{:.7f},{:.7f},{:.7f},{:.7f},{}\n", frame, t, p[0], p[1], p[2], q[0],
                         q[1], q[2], q[3], live ? 1 : 0);
    }
    if (!opt.bvh) continue;
    const json& f = r.at(j, "fighter", "fighter");
    if (!f.value("present", false)) r.fail("fighter.present", "no fighter in this frame: nothing to export");
    const int character = static_cast<int>(r.num(r.at(f, "character", "fighter.character"), "fighter.character")) - 1;
    if (runs.empty() || character != runs.back().info.character) {
      if (character < 0 || character >= static_cast<int>(config.characters.size()))
        r.fail("fighter.character", fmt::format("character {} is not in {} ({} characters)", character + 1,
                                                config.file.string(), config.characters.size()));
      const auto& ch = config.characters[static_cast<std::size_t>(character)];
      const std::string logged_name = f.value("character_name", "");
      if (!logged_name.empty() && logged_name != ch.name)
        r.fail("fighter.character_name", fmt::format("\"{}\" but {} names character {} \"{}\": the log is from another "
                                                     "installation file", logged_name, config.file.string(), character + 1, ch.name));
      const content::Clip character_bvh = content::read_bvh(config.resolve(ch.bvh));
      Run& run = runs.emplace_back();
      run.info.character = character;
      run.info.character_name = ch.name;
      run.info.first_frame = frame;
      run.info.first_time_s = t;
      run.clip.name = ch.name;
      run.clip.skeleton = character_bvh.skeleton;
      run.clip.unit_m = character_bvh.unit_m;
      run.clip.frame_count = 0;
    }
    Run& run = runs.back();
    content::Clip& clip = run.clip;
    ++run.info.frames;
    run.info.last_frame = frame;
    run.info.last_time_s = t;
    const json& rot = r.at(f, "local_rotations", "fighter.local_rotations");
    const auto root = r.nums<3>(r.at(f, "root_joint", "fighter.root_joint"), "fighter.root_joint");
    clip.root_positions.emplace_back(root[0], root[1], root[2]);
    const auto& names = clip.skeleton.names;
    for (std::size_t k = 0; k < names.size(); ++k) {
      const std::string key = "fighter.local_rotations." + names[k];
      const auto q = r.nums<4>(r.at(rot, names[k], key), key);
      Eigen::Quaterniond qq(q[0], q[1], q[2], q[3]);
      if (std::abs(qq.norm() - 1) > 1e-3) r.fail(key, fmt::format("not a unit quaternion (norm {:.6f})", qq.norm()));
      clip.local_rotations.push_back(qq.normalized());
    }
    ++clip.frame_count;
  }
  if (rep.frames == 0)
    throw Error("export", "empty", fmt::format("{}: no frame with time_s in [{}, {}] s", opt.log.string(), opt.from_s, opt.to_s));
  if (opt.bvh) {
    // Each run's frame time is the mean interval of its frames; a run of one frame takes the
    // whole interval's.
    const double whole_dt = rep.frames > 1 ? (rep.last_time_s - rep.first_time_s) / (rep.frames - 1) : 1.0 / 60;
    for (std::size_t i = 0; i < runs.size(); ++i) {
      Run& run = runs[i];
      double dt = run.info.frames > 1 ? (run.info.last_time_s - run.info.first_time_s) / (run.info.frames - 1) : whole_dt;
      if (!(dt > 0)) dt = 1.0 / 60;
      run.clip.frame_time_s = dt;
      run.info.frame_time_s = dt;
      run.info.bvh = runs.size() == 1 ? *opt.bvh : run_bvh_path(*opt.bvh, static_cast<int>(i), run.info.character_name);
    }
    // Written once every frame has been read: a bad line later in the interval leaves no file.
    for (const Run& run : runs) content::write_bvh(run.info.bvh, run.clip);
    for (Run& run : runs) rep.runs.push_back(std::move(run.info));
    rep.character = rep.runs.front().character;
    rep.character_name = rep.runs.front().character_name;
    rep.frame_time_s = rep.runs.front().frame_time_s;
  }
  if (opt.head_csv) write_file_atomically(*opt.head_csv, csv);
  return rep;
}

}  // namespace kumite::app
