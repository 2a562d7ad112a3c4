// poses.csv: what kumite-track --out writes and what the installation's poses source, the
// recognition thread's tests and kumite-recognise run read (issue 14).
#include "kumite/recognition/poses_file.hpp"

#include "kumite/common/text.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "kumite/common/error.hpp"

namespace kumite::recognition {

PosesFile parse_poses_csv(std::string_view text, std::string_view source) {
  text = without_utf8_bom(text);  // a spreadsheet's "CSV UTF-8"
  PosesFile out;
  bool header = false;
  double last_t = -std::numeric_limits<double>::infinity();
  int line = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t e = text.find('\n', pos);
    if (e == std::string_view::npos) e = text.size();
    std::string_view l = text.substr(pos, e - pos);
    pos = e + 1;
    ++line;
    while (!l.empty() && (l.back() == '\r' || l.back() == ' ' || l.back() == '\t')) l.remove_suffix(1);
    while (!l.empty() && (l.front() == ' ' || l.front() == '\t')) l.remove_prefix(1);
    if (l.empty() || l.front() == '#') continue;
    auto fail = [&](std::string_view key, const std::string& msg) {
      return file_error("recognition", "poses", source, line, key, msg);
    };
    if (!header) {
      if (l != kPosesHeader) throw fail("header", fmt::format("expected the header \"{}\"", kPosesHeader));
      header = true;
      continue;
    }
    std::vector<std::string_view> f;
    std::size_t i = 0;
    while (true) {
      const std::size_t c = l.find(',', i);
      f.push_back(l.substr(i, c == std::string_view::npos ? std::string_view::npos : c - i));
      if (c == std::string_view::npos) break;
      i = c + 1;
    }
    if (f.size() != 14) throw fail("row", fmt::format("{} columns, expected 14 ({})", f.size(), kPosesHeader));
    static const char* names[14] = {"frame", "timestamp_s", "body", "status", "x", "y", "z", "qw", "qx", "qy", "qz",
                                    "markers", "cameras", "latency_ms"};
    auto num = [&](int k, double lo, double hi) {
      double v = 0;
      const std::string_view tok = f[static_cast<std::size_t>(k)];
      const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
      if (tok.empty() || ec != std::errc() || p != tok.data() + tok.size())
        throw fail(names[k], fmt::format("'{}' is not a number", tok));
      if (!std::isfinite(v) || v < lo || v > hi) throw fail(names[k], fmt::format("{} is outside [{}, {}]", tok, lo, hi));
      return v;
    };
    num(0, 0, 1e15);
    const double t = num(1, -1e9, 1e12);
    if (t < last_t) throw fail("timestamp_s", fmt::format("{} goes back in time (previous row {})", t, last_t));
    last_t = t;
    const std::string_view status = f[3];
    if (status != "tracked" && status != "coasting" && status != "lost")
      throw fail("status", fmt::format("'{}' is not tracked, coasting or lost", status));
    PoseSample s;
    s.t = t;
    s.tracked = status != "lost";
    for (int k = 0; k < 3; ++k) s.position[static_cast<std::size_t>(k)] = num(4 + k, -100, 100);
    for (int k = 0; k < 4; ++k) s.orientation[static_cast<std::size_t>(k)] = num(7 + k, -1.01, 1.01);
    const double qn = std::sqrt(s.orientation[0] * s.orientation[0] + s.orientation[1] * s.orientation[1] +
                                s.orientation[2] * s.orientation[2] + s.orientation[3] * s.orientation[3]);
    if (s.tracked && std::abs(qn - 1) > 0.01) throw fail("qw", fmt::format("orientation norm {:.4f} is not 1", qn));
    num(11, 0, 1e6);
    num(12, 0, 1e6);
    num(13, -1, 1e6);
    const auto role = role_from_string(f[2]);
    if (!role) {
      ++out.ignored_rows;
      continue;
    }
    s.role = *role;
    out.samples.push_back(s);
  }
  if (!header) throw file_error("recognition", "poses", source, line, "header", "no header line: empty poses file");
  return out;
}

PosesFile read_poses_csv(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error("recognition", "io", path.string(), 0, "", "cannot open the poses file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_poses_csv(ss.str(), path.string());
}

std::string format_poses_csv(const std::vector<PoseSample>& samples) {
  std::string out = std::string(kPosesHeader) + "\n";
  long frame = -1;
  double last = std::nan("");
  for (const PoseSample& s : samples) {
    if (!(s.t == last)) {
      ++frame;
      last = s.t;
    }
    out += fmt::format("{},{:.6f},{},{},{:.5f},{:.5f},{:.5f},{:.6f},{:.6f},{:.6f},{:.6f},{},{},{}\n", frame, s.t,
                       to_string(s.role), s.tracked ? "tracked" : "lost", s.position[0], s.position[1], s.position[2],
                       s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3], s.tracked ? 4 : 0,
                       s.tracked ? 4 : 0, 0);
  }
  return out;
}

}  // namespace kumite::recognition
