// The model file (.krec): versioned text with a checksum.
//
//   kumite-recognition-model 1
//   checksum fnv1a64 0123456789abcdef        (of every byte after this line)
//   note <one line>
//   setting <name> <value>                   (every RecogniserSettings field)
//   template <action> <hand|foot> frames <n> hit <h> threshold <d> trials <k>
//   thresholds <m> <m numbers>               (per buffer length 1..m; m = 0: `threshold`)
//   <9 numbers>                              (n lines: a Feature)
//   end
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <sstream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/text.hpp"
#include "kumite/recognition/recognition.hpp"
#include "model_text.hpp"

namespace kumite::recognition {

namespace {
using detail::fnv1a64;
using detail::split;
constexpr std::string_view kMagic = "kumite-recognition-model";

struct SettingField {
  std::string_view name;
  std::function<double&(RecogniserSettings&)> ref;
  double lo, hi;
  bool integer;
};
const std::vector<SettingField>& setting_fields() {
  static const std::vector<SettingField> f = {
      {"loop_hz", [](RecogniserSettings& s) -> double& { return s.frontend.loop_hz; }, 10, 1000, false},
      {"smoothing_tau_s", [](RecogniserSettings& s) -> double& { return s.frontend.smoothing_tau_s; }, 1e-4, 1, false},
      {"heading_tau_s", [](RecogniserSettings& s) -> double& { return s.frontend.heading_tau_s; }, 1e-3, 10, false},
      {"height_tau_s", [](RecogniserSettings& s) -> double& { return s.frontend.height_tau_s; }, 1e-2, 100, false},
      {"velocity_weight", [](RecogniserSettings& s) -> double& { return s.frontend.velocity_weight; }, 0, 10, false},
      {"max_gap_s", [](RecogniserSettings& s) -> double& { return s.frontend.max_gap_s; }, 1e-3, 10, false},
      {"onset_speed", [](RecogniserSettings& s) -> double& { return s.onset_speed; }, 0, 20, false},
      {"null_speed", [](RecogniserSettings& s) -> double& { return s.null_speed; }, 0, 20, false},
      {"switch_margin", [](RecogniserSettings& s) -> double& { return s.switch_margin; }, 0, 1, false},
    {"absolute_weight", [](RecogniserSettings& s) -> double& { return s.absolute_weight; }, 0, 10, false},
    {"none_margin", [](RecogniserSettings& s) -> double& { return s.none_margin; }, 0, 10, false},
  };
  return f;
}
struct IntField {
  std::string_view name;
  int RecogniserSettings::*ptr;
  int lo, hi;
};
constexpr IntField kIntFields[] = {
    {"null_frames", &RecogniserSettings::null_frames, 1, 1000},
    {"main_frames", &RecogniserSettings::main_frames, 1, 1000},
    {"max_frames", &RecogniserSettings::max_frames, 1, 10000},
    {"discard_frames", &RecogniserSettings::discard_frames, 0, 10000},
    {"rearm_frames", &RecogniserSettings::rearm_frames, 1, 10000},
    {"lead_frames", &RecogniserSettings::lead_frames, 0, 1},
};

bool valid_name(std::string_view s) {
  return !s.empty() && s.size() <= 64 &&
         std::all_of(s.begin(), s.end(), [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'; });
}

}  // namespace

std::string format_model(const Model& m) {
  std::string body;
  std::string note = m.note;
  std::replace(note.begin(), note.end(), '\n', ' ');
  body += fmt::format("note {}\n", note);
  RecogniserSettings s = m.settings;
  for (const auto& f : setting_fields()) body += fmt::format("setting {} {:.17g}\n", f.name, f.ref(s));
  for (const auto& f : kIntFields) body += fmt::format("setting {} {}\n", f.name, s.*(f.ptr));
  body += fmt::format("setting one_at_a_time {}\n", s.one_at_a_time ? 1 : 0);
  for (const Template& t : m.templates) {
    body += fmt::format("template {} {} frames {} hit {} threshold {:.17g} trials {}\n", t.action,
                        to_string(t.kind), t.frames.size(), t.hit, t.threshold, t.trials);
    body += fmt::format("thresholds {}", t.thresholds.size());
    for (double v : t.thresholds) body += fmt::format(" {:.17g}", v);
    body += "\n";
    for (const Feature& f : t.frames)
      body += fmt::format("{:.9g}\n", fmt::join(f, " "));
  }
  body += "end\n";
  return fmt::format("{} {}\nchecksum fnv1a64 {:016x}\n", kMagic, Model::kVersion, fnv1a64(body)) + body;
}

Model parse_model(std::string_view text, std::string_view source) {
  auto fail = [&](int line, std::string_view key, std::string_view msg) {
    return file_error("recognition", "model", source, line, key, msg);
  };
  const std::vector<std::string_view> lines = detail::lines_of(text);
  if (lines.empty()) throw fail(1, "format", "empty file: not a kumite recognition model");
  {
    const auto w = split(trim_blanks(lines[0]));
    if (w.size() != 2 || w[0] != kMagic)
      throw fail(1, "format", fmt::format("not a kumite recognition model (first line must be \"{} {}\")", kMagic, Model::kVersion));
    if (w[1] != std::to_string(Model::kVersion))
      throw fail(1, "version", fmt::format("model version {} is not the version this build reads ({})", w[1], Model::kVersion));
  }
  if (lines.size() < 2) throw fail(2, "checksum", "missing");
  {
    const auto w = split(trim_blanks(lines[1]));
    if (w.size() != 3 || w[0] != "checksum" || w[1] != "fnv1a64") throw fail(2, "checksum", "expected \"checksum fnv1a64 <16 hex digits>\"");
    const std::size_t body_start = lines[0].size() + 1 + lines[1].size() + 1;
    const std::string_view body = body_start <= text.size() ? text.substr(body_start) : std::string_view{};
    if (w[2] != fmt::format("{:016x}", fnv1a64(body)))
      throw fail(2, "checksum", "does not match the contents (file damaged or edited)");
  }
  auto number = [&](std::string_view tok, int line, std::string_view key, double lo, double hi) {
    double v = 0;
    const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec != std::errc() || p != tok.data() + tok.size()) throw fail(line, key, fmt::format("'{}' is not a number", tok));
    if (!std::isfinite(v) || v < lo || v > hi) throw fail(line, key, fmt::format("{} is outside [{}, {}]", tok, lo, hi));
    return v;
  };
  auto integer = [&](std::string_view tok, int line, std::string_view key, int lo, int hi) {
    int v = 0;
    const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec != std::errc() || p != tok.data() + tok.size()) throw fail(line, key, fmt::format("'{}' is not an integer", tok));
    if (v < lo || v > hi) throw fail(line, key, fmt::format("{} is outside [{}, {}]", v, lo, hi));
    return v;
  };
  Model m;
  bool ended = false;
  std::vector<bool> seen_setting(setting_fields().size() + std::size(kIntFields), false);
  for (std::size_t li = 2; li < lines.size(); ++li) {
    const int line = static_cast<int>(li + 1);
    const std::string_view l = trim_blanks(lines[li]);
    if (l.empty()) continue;
    if (ended) throw fail(line, "end", "text after \"end\"");
    const auto w = split(l);
    if (w[0] == "note") {
      m.note = std::string(trim_blanks(l.substr(4)));
    } else if (w[0] == "setting") {
      if (w.size() != 3) throw fail(line, "setting", "expected \"setting <name> <value>\"");
      bool known = false;
      for (std::size_t i = 0; i < setting_fields().size(); ++i) {
        const auto& f = setting_fields()[i];
        if (f.name != w[1]) continue;
        f.ref(m.settings) = number(w[2], line, f.name, f.lo, f.hi);
        seen_setting[i] = known = true;
      }
      for (std::size_t i = 0; i < std::size(kIntFields); ++i) {
        const auto& f = kIntFields[i];
        if (f.name != w[1]) continue;
        m.settings.*(f.ptr) = integer(w[2], line, f.name, f.lo, f.hi);
        seen_setting[setting_fields().size() + i] = known = true;
      }
      if (w[1] == "one_at_a_time") {
        m.settings.one_at_a_time = integer(w[2], line, "one_at_a_time", 0, 1) == 1;
        known = true;
      }
      if (!known) throw fail(line, w[1], "unknown setting");
    } else if (w[0] == "template") {
      if (w.size() != 11 || w[3] != "frames" || w[5] != "hit" || w[7] != "threshold" || w[9] != "trials")
        throw fail(line, "template", "expected \"template <action> <hand|foot> frames <n> hit <h> threshold <d> trials <k>\"");
      Template t;
      if (!valid_name(w[1])) throw fail(line, "action", fmt::format("'{}' is not a name (a-z, 0-9, _)", w[1]));
      t.action = std::string(w[1]);
      const auto kind = limb_kind_from_string(w[2]);
      if (!kind) throw fail(line, "kind", fmt::format("'{}' is not hand or foot", w[2]));
      t.kind = *kind;
      const int n = integer(w[4], line, "frames", 2, 10000);
      t.hit = integer(w[6], line, "hit", 0, n - 1);
      t.threshold = number(w[8], line, "threshold", 1e-9, 1e6);
      t.trials = integer(w[10], line, "trials", 1, 1000000);
      {
        ++li;
        const int tl = static_cast<int>(li + 1);
        if (li >= lines.size()) throw fail(tl, "thresholds", "missing after the template line");
        const auto v = split(trim_blanks(lines[li]));
        if (v.size() < 2 || v[0] != "thresholds") throw fail(tl, "thresholds", "expected \"thresholds <m> <m numbers>\"");
        const int k = integer(v[1], tl, "thresholds", 0, 10000);
        if (static_cast<int>(v.size()) != k + 2) throw fail(tl, "thresholds", fmt::format("{} numbers announced, {} given", k, v.size() - 2));
        for (int i = 0; i < k; ++i) t.thresholds.push_back(number(v[static_cast<std::size_t>(i + 2)], tl, "thresholds", 1e-9, 1e6));
      }
      for (int i = 0; i < n; ++i) {
        ++li;
        if (li >= lines.size()) throw fail(static_cast<int>(li), "frames", fmt::format("template {} ends after {} of {} frames", t.action, i, n));
        const auto v = split(trim_blanks(lines[li]));
        const int fl = static_cast<int>(li + 1);
        if (v.size() != kFeatureDim) throw fail(fl, "frames", fmt::format("expected {} numbers, got {}", kFeatureDim, v.size()));
        Feature f{};
        for (int d = 0; d < kFeatureDim; ++d)
          f[static_cast<std::size_t>(d)] = static_cast<float>(number(v[static_cast<std::size_t>(d)], fl, "frames", -100, 100));
        t.frames.push_back(f);
      }
      for (const Template& o : m.templates)
        if (t.action != kNoneAction && o.action == t.action && o.kind == t.kind) throw fail(line, "template", fmt::format("{} {} appears twice", t.action, to_string(t.kind)));
      m.templates.push_back(std::move(t));
    } else if (w[0] == "end") {
      ended = true;
    } else {
      throw fail(line, w[0], "unknown line");
    }
  }
  if (!ended) throw fail(static_cast<int>(lines.size()), "end", "missing (file cut short)");
  for (std::size_t i = 0; i < seen_setting.size(); ++i)
    if (!seen_setting[i])
      throw fail(0, i < setting_fields().size() ? setting_fields()[i].name : kIntFields[i - setting_fields().size()].name, "setting missing");
  if (std::none_of(m.templates.begin(), m.templates.end(), [](const Template& t) { return t.action != kNoneAction; }))
    throw fail(0, "template", "the model has no strike templates");
  if (m.settings.main_frames > m.settings.max_frames) throw fail(0, "main_frames", "larger than max_frames");
  return m;
}

Model read_model(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error("recognition", "io", path.string(), 0, "", "cannot open the model file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_model(ss.str(), path.string());
}

void write_model(const std::filesystem::path& path, const Model& m) {
  write_file_atomically(path, format_model(m));
}

}  // namespace kumite::recognition
