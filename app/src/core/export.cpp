#include "kumite/app/export.hpp"

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

ExportReport export_log(const InstallationConfig& config, const ExportOptions& opt) {
  if (!std::isfinite(opt.from_s) || !std::isfinite(opt.to_s) || opt.to_s < opt.from_s)
    throw Error("cli", "range", fmt::format("--from {} --to {}: expected finite times with from <= to", opt.from_s, opt.to_s));
  std::ifstream in(opt.log, std::ios::binary);
  if (!in) throw Error("io", "open", fmt::format("{}: cannot read", opt.log.string()));
  JsonLineReader r{"export", "log", opt.log.string(), 0};
  ExportReport rep;

  content::Clip clip;  // the fighter, once its character is known
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
    if (rep.character < 0) {
      if (character < 0 || character >= static_cast<int>(config.characters.size()))
        r.fail("fighter.character", fmt::format("character {} is not in {} ({} characters)", character + 1,
                                                config.file.string(), config.characters.size()));
      const auto& ch = config.characters[static_cast<std::size_t>(character)];
      const std::string logged_name = f.value("character_name", "");
      if (!logged_name.empty() && logged_name != ch.name)
        r.fail("fighter.character_name", fmt::format("\"{}\" but {} names character {} \"{}\": the log is from another "
                                                     "installation file", logged_name, config.file.string(), character + 1, ch.name));
      const content::Clip character_bvh = content::read_bvh(config.resolve(ch.bvh));
      rep.character = character;
      rep.character_name = ch.name;
      clip.name = ch.name;
      clip.skeleton = character_bvh.skeleton;
      clip.unit_m = character_bvh.unit_m;
      clip.frame_count = 0;
    } else if (character != rep.character) {
      r.fail("fighter.character", fmt::format("the character changes from {} to {} at frame {} ({:.3f} s): export an "
                                              "interval with one character", rep.character + 1, character + 1, frame, t));
    }
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
    clip.frame_time_s = rep.frames > 1 ? (rep.last_time_s - rep.first_time_s) / (rep.frames - 1) : 1.0 / 60;
    if (!(clip.frame_time_s > 0)) clip.frame_time_s = 1.0 / 60;
    rep.frame_time_s = clip.frame_time_s;
    content::write_bvh(*opt.bvh, clip);
  }
  if (opt.head_csv) write_file_atomically(*opt.head_csv, csv);
  return rep;
}

}  // namespace kumite::app
