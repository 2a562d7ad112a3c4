#include "kumite/tracking/recording.hpp"

#include <algorithm>
#include <charconv>
#include <span>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/image_file.hpp"

namespace kumite::tracking {
namespace fs = std::filesystem;

namespace {

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    std::string_view f = line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    while (!f.empty() && (f.front() == ' ' || f.front() == '\t')) f.remove_prefix(1);
    while (!f.empty() && (f.back() == ' ' || f.back() == '\t' || f.back() == '\r')) f.remove_suffix(1);
    out.push_back(f);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

bool parse_u64(std::string_view s, std::uint64_t& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && !s.empty();
}

bool parse_double(std::string_view s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && !s.empty() && std::isfinite(v);
}

/// Calls row(fields, line number) for every data line after checking the header.
template <typename Row>
void for_each_row(std::string_view text, std::string_view source, std::span<const std::string_view> header,
                  std::vector<std::string>& skipped, Row&& row) {
  std::size_t pos = 0;
  int line_no = 0;
  bool have_header = false;
  while (pos <= text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.find_first_not_of(" \t") == std::string_view::npos) {
      if (end == text.size()) break;
      continue;
    }
    const auto fields = split(line);
    if (!have_header) {
      bool ok = fields.size() >= header.size();
      for (std::size_t i = 0; ok && i < header.size(); ++i) ok = fields[i] == header[i];
      if (!ok) {
        std::string want;
        for (auto h : header) want += (want.empty() ? "" : ",") + std::string(h);
        throw file_error("recording", "header", source, line_no, "", "expected the header \"" + want + "\"");
      }
      have_header = true;
    } else if (fields.size() < header.size()) {
      skipped.push_back(format_location(source, line_no, "",
                                        fmt::format("expected {} fields, found {}: row skipped", header.size(), fields.size())));
    } else {
      row(fields, line_no);
    }
    if (end == text.size()) break;
  }
  if (!have_header) throw file_error("recording", "header", source, 0, "", "empty file (no header)");
}

}  // namespace

FramesIndex parse_frames_csv(std::string_view text, std::string_view source) {
  static constexpr std::string_view kHeader[] = {"frame", "timestamp_s"};
  FramesIndex out;
  for_each_row(text, source, kHeader, out.skipped, [&](const std::vector<std::string_view>& f, int line) {
    FrameRow r;
    if (!parse_u64(f[0], r.frame)) {
      out.skipped.push_back(format_location(source, line, "frame", "not a frame number: row skipped"));
      return;
    }
    if (!parse_double(f[1], r.timestamp)) {
      out.skipped.push_back(format_location(source, line, "timestamp_s", "not a number: row skipped"));
      return;
    }
    if (!out.rows.empty()) {
      const FrameRow& prev = out.rows.back();
      if (r.frame <= prev.frame) {
        out.skipped.push_back(format_location(source, line, "frame",
            fmt::format("frame {} does not follow frame {}: row skipped", r.frame, prev.frame)));
        return;
      }
      if (r.timestamp < prev.timestamp) {
        out.skipped.push_back(format_location(source, line, "timestamp_s",
            fmt::format("goes backwards ({} < {}): row skipped", r.timestamp, prev.timestamp)));
        return;
      }
    }
    out.rows.push_back(r);
  });
  return out;
}

TruthTable parse_truth_csv(std::string_view text, std::string_view source) {
  static constexpr std::string_view kHeader[] = {"frame", "timestamp_s", "x", "y", "z", "qw", "qx", "qy", "qz"};
  TruthTable out;
  for_each_row(text, source, kHeader, out.skipped, [&](const std::vector<std::string_view>& f, int line) {
    TruthRow r;
    double v[7];
    bool ok = parse_u64(f[0], r.frame) && parse_double(f[1], r.timestamp);
    for (int k = 0; ok && k < 7; ++k) ok = parse_double(f[2 + k], v[k]);
    if (!ok) {
      out.skipped.push_back(format_location(source, line, "", "malformed row: skipped"));
      return;
    }
    const double qn = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
    if (qn < 0.5 || qn > 1.5) {
      out.skipped.push_back(format_location(source, line, "qw", "not a unit quaternion: row skipped"));
      return;
    }
    r.x = v[0], r.y = v[1], r.z = v[2];
    r.qw = v[3] / qn, r.qx = v[4] / qn, r.qy = v[5] / qn, r.qz = v[6] / qn;
    if (!out.rows.empty() && r.frame <= out.rows.back().frame) {
      out.skipped.push_back(format_location(source, line, "frame", "not increasing: row skipped"));
      return;
    }
    out.rows.push_back(r);
  });
  return out;
}

const TruthRow* TruthTable::find(std::uint64_t frame) const {
  auto it = std::lower_bound(rows.begin(), rows.end(), frame,
                             [](const TruthRow& r, std::uint64_t f) { return r.frame < f; });
  return it != rows.end() && it->frame == frame ? &*it : nullptr;
}

std::string frame_file_name(std::uint64_t frame) { return fmt::format("{:06d}.png", frame); }

namespace {
std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("recording", "missing", fmt::format("{}: cannot open", path.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

Recording::Recording(const fs::path& dir, const RigCalibration& rig) : dir_(dir) {
  if (!fs::is_directory(dir)) {
    throw Error("recording", "missing", fmt::format("{}: not a recording folder", dir.string()));
  }
  const fs::path frames = dir / "frames.csv";
  if (!fs::exists(frames)) {
    throw Error("recording", "missing", fmt::format("{}: missing (every recording needs frames.csv)", frames.string()));
  }
  index_ = parse_frames_csv(read_text(frames), frames.string());
  if (fs::exists(dir / "truth.csv")) truth_ = parse_truth_csv(read_text(dir / "truth.csv"), (dir / "truth.csv").string());
  if (fs::exists(dir / "README.txt")) {
    synthetic_ = read_text(dir / "README.txt").find("SYNTHETIC") != std::string::npos;
  }
  int folders = 0;
  for (const auto& cam : rig.cameras) {
    names_.push_back(cam.name);
    sizes_.emplace_back(cam.image_width, cam.image_height);
    const bool has = fs::is_directory(dir / cam.name);
    has_folder_.push_back(has);
    folders += has;
    if (!has) {
      warnings_.push_back(fmt::format("{}: no folder for calibrated camera \"{}\": it gives no images",
                                      dir.string(), cam.name));
    }
  }
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_directory()) continue;
    const std::string name = entry.path().filename().string();
    if (!rig.find(name)) {
      warnings_.push_back(fmt::format("{}: folder \"{}\" is not a camera in the calibration: ignored",
                                      dir.string(), name));
    }
  }
  if (folders == 0) {
    throw Error("recording", "cameras",
                fmt::format("{}: no folder matches a calibrated camera (expected e.g. {}/)", dir.string(),
                            names_.empty() ? std::string("cam0") : names_.front()));
  }
}

cv::Mat read_grey_image(const fs::path& file, std::string& why) {
  try {
    const std::vector<unsigned char> bytes = read_file_bytes(file);
    why = incomplete_image(bytes);
    if (!why.empty()) return {};
    cv::Mat img = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<unsigned char*>(bytes.data())),
                               cv::IMREAD_GRAYSCALE);
    if (img.empty()) why = "cannot decode the image";
    return img;
  } catch (const Error&) {
    why = "cannot read the file";
  } catch (const cv::Exception&) {
    why = "cannot decode the image";
  }
  return {};
}

FrameSet Recording::load(std::size_t i, std::vector<std::string>* skipped,
                         std::vector<std::size_t>* skipped_cameras) const {
  const FrameRow& row = index_.rows.at(i);
  FrameSet set;
  set.frame = row.frame;
  set.timestamp = row.timestamp;
  set.images.resize(names_.size());
  set.camera_times.assign(names_.size(), row.timestamp);
  for (std::size_t c = 0; c < names_.size(); ++c) {
    if (!has_folder_[c]) continue;
    const fs::path file = dir_ / names_[c] / frame_file_name(row.frame);
    std::error_code ec;
    if (!fs::exists(file, ec)) continue;  // that camera delivered no image for this frame set
    std::string why;
    cv::Mat img = read_grey_image(file, why);
    if (img.empty()) {
      if (skipped) skipped->push_back(fmt::format("{}: {}: skipped", file.string(), why));
      if (skipped_cameras) skipped_cameras->push_back(c);
      continue;
    }
    if (img.size() != sizes_[c]) {
      if (skipped) {
        skipped->push_back(fmt::format("{}: {}x{} image, the calibration says {}x{}: skipped", file.string(),
                                       img.cols, img.rows, sizes_[c].width, sizes_[c].height));
      }
      if (skipped_cameras) skipped_cameras->push_back(c);
      continue;
    }
    set.images[c] = std::move(img);
  }
  return set;
}

void write_frames_csv(const fs::path& path, const std::vector<FrameRow>& rows) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << "frame,timestamp_s\n";
    for (const auto& r : rows) out << fmt::format("{},{:.6f}\n", r.frame, r.timestamp);
  });
}

void write_truth_csv(const fs::path& path, const std::vector<TruthRow>& rows) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << "frame,timestamp_s,x,y,z,qw,qx,qy,qz\n";
    for (const auto& r : rows) {
      out << fmt::format("{},{:.6f},{:.7f},{:.7f},{:.7f},{:.9f},{:.9f},{:.9f},{:.9f}\n", r.frame, r.timestamp, r.x,
                         r.y, r.z, r.qw, r.qx, r.qy, r.qz);
    }
  });
}

}  // namespace kumite::tracking
