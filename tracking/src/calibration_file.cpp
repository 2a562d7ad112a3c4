#include "kumite/tracking/calibration_file.hpp"

#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core/persistence.hpp>
#include <yaml.h>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"

namespace kumite::tracking {
namespace fs = std::filesystem;

const CameraCalibration* RigCalibration::find(const std::string& name) const {
  for (const auto& c : cameras) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

namespace {

[[noreturn]] void fail(const fs::path& path, const std::string& where, const std::string& what) {
  throw file_error("calibration", "invalid", path.string(), 0, where, what);
}

/// The first line holding one of YAML's non-finite numbers (.nan, .inf, +.inf, -.inf, in any
/// case) as a value of its own; 0 where none is found. Read again only to say where a
/// non-finite number stands (OpenCV's FileStorage gives no line).
int nonfinite_line(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::string lower(line);
    for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    for (const char* word : {".nan", ".inf"}) {
      for (std::size_t at = lower.find(word); at != std::string::npos; at = lower.find(word, at + 1)) {
        std::size_t before = at;
        if (before > 0 && (lower[before - 1] == '-' || lower[before - 1] == '+')) --before;
        const bool starts = before == 0 || std::string_view(" \t[,:").find(lower[before - 1]) != std::string_view::npos;
        const std::size_t after = at + 4;
        const bool ends = after == lower.size() || std::string_view(" \t],\r#").find(lower[after]) != std::string_view::npos;
        if (starts && ends) return n;
      }
    }
  }
  return 0;
}

[[noreturn]] void fail_nonfinite(const fs::path& path, const std::string& where) {
  throw file_error("calibration", "invalid", path.string(), nonfinite_line(path), where, "must be a finite number");
}

/// OpenCV allocates rows x cols before reading the data: refuse absurd sizes first (a
/// corrupted "rows: 300000000" would otherwise ask for gigabytes).
void check_matrix_size(const cv::FileNode& node, const fs::path& path, const std::string& where) {
  if (!node.isMap()) return;
  const cv::FileNode r = node["rows"], c = node["cols"];
  if (!r.isInt() || !c.isInt()) fail(path, where, "not a matrix (rows and cols must be integers)");
  const long long n = static_cast<long long>(static_cast<int>(r)) * static_cast<int>(c);
  if (static_cast<int>(r) < 0 || static_cast<int>(c) < 0 || n > (1 << 20)) fail(path, where, "matrix too large");
  if (static_cast<long long>(node["data"].size()) < n) fail(path, where, "matrix data shorter than rows x cols");
}

cv::Mat read_matrix(const cv::FileNode& cam, const char* key, int rows, int cols,
                    const fs::path& path, const std::string& where) {
  const cv::FileNode node = cam[key];
  if (node.empty()) fail(path, where + "." + key, "missing");
  cv::Mat m;
  check_matrix_size(node, path, where + "." + key);
  try {
    node >> m;
  } catch (const cv::Exception&) {
    fail(path, where + "." + key, "not a matrix");
  }
  if (m.empty()) fail(path, where + "." + key, "not a matrix");
  // Accept a 5x1 distortion as well as 1x5 (both appear in the wild).
  if (m.rows * m.cols == rows * cols && (m.rows == cols && m.cols == rows)) m = m.reshape(1, rows);
  if (m.rows != rows || m.cols != cols) {
    fail(path, where + "." + key,
         fmt::format("expected {}x{}, found {}x{}", rows, cols, m.rows, m.cols));
  }
  m.convertTo(m, CV_64F);
  for (int i = 0; i < m.rows * m.cols; ++i) {
    if (!std::isfinite(m.at<double>(i))) fail_nonfinite(path, where + "." + key);
  }
  return m;
}

int read_positive_int(const cv::FileNode& cam, const char* key, const fs::path& path,
                      const std::string& where) {
  const cv::FileNode node = cam[key];
  if (node.empty()) fail(path, where + "." + key, "missing");
  if (!node.isInt()) fail(path, where + "." + key, "must be an integer");
  const int v = static_cast<int>(node);
  if (v <= 0) fail(path, where + "." + key, "must be positive");
  return v;
}

RigCalibration read_calibration_unchecked(const fs::path& path);

/// The whole file through libyaml (a YAML 1.1 parser fuzzed upstream) before OpenCV sees it:
/// OpenCV 4.6's FileStorage parser loops forever on some malformed files ("[0,]  -" after a
/// flow sequence, found by fuzzing in session 23, after the patterns check_yaml_text refuses);
/// what libyaml refuses is one line naming the file, line and column. OpenCV's "%YAML:1.0"
/// header is not YAML's "%YAML 1.1": it is read as the latter (same line count).
void check_yaml_parses(const fs::path& path, std::string text) {
  if (text.rfind("%YAML:", 0) == 0) text.replace(0, text.find('\n'), "%YAML 1.1");
  yaml_parser_t parser;
  if (!yaml_parser_initialize(&parser)) throw file_error("calibration", "io", path.string(), 0, "", "cannot start the YAML parser");
  struct Done {
    yaml_parser_t* p;
    ~Done() { yaml_parser_delete(p); }
  } done{&parser};
  yaml_parser_set_input_string(&parser, reinterpret_cast<const unsigned char*>(text.data()), text.size());
  for (;;) {
    yaml_event_t event;
    if (!yaml_parser_parse(&parser, &event)) {
      const std::string problem = parser.problem ? parser.problem : "not valid YAML";
      const std::string context = parser.context ? std::string(" ") + parser.context : "";
      throw file_error("calibration", "parse", path.string(), static_cast<int>(parser.problem_mark.line) + 1, "",
                       fmt::format("not valid YAML: {}{} (column {})", problem, context, parser.problem_mark.column + 1));
    }
    const bool end = event.type == YAML_STREAM_END_EVENT;
    yaml_event_delete(&event);
    if (end) return;
  }
}

/// OpenCV 4.6's YAML parser loops forever on some malformed files (found by fuzzing: control
/// bytes inside numbers; a block line dedenting to a level that was never opened). A
/// calibration file is plain text with consistent block indentation: check that first.
void check_yaml_text(const fs::path& path, const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::vector<std::size_t> indents;  // open block indentation levels
  int flow = 0;                      // depth inside [ ] / { }
  std::size_t flow_indent = 0;       // indentation of the line that opened it
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    for (const unsigned char ch : line) {
      if ((ch < 0x20 && ch != '\t' && ch != '\r') || ch == 0x7f) {
        throw file_error("calibration", "parse", path.string(), n, "",
                         fmt::format("not a text file (control byte 0x{:02x})", ch));
      }
    }
    // Lines end where both parsers end them: libyaml (check_yaml_parses) also breaks lines at a
    // lone carriage return and at U+0085 / U+2028 / U+2029, OpenCV does not; a file the two
    // read as different documents passed libyaml and hung OpenCV ("\rK" on a line, found by
    // fuzzing in session 23). A carriage return only ends a line (CRLF).
    if (const auto cr = line.find('\r'); cr != std::string::npos && cr + 1 != line.size()) {
      throw file_error("calibration", "parse", path.string(), n, "", "a carriage return inside a line");
    }
    for (const std::string_view sep : {std::string_view("\xc2\x85"), std::string_view("\xe2\x80\xa8"), std::string_view("\xe2\x80\xa9")}) {
      if (line.find(sep) != std::string::npos) throw file_error("calibration", "parse", path.string(), n, "", "a Unicode line separator inside a line");
    }
    // Valid UTF-8 only (OpenCV's parser mishandles stray high bytes).
    for (std::size_t i = 0; i < line.size();) {
      const auto b = static_cast<unsigned char>(line[i]);
      const int len = b < 0x80 ? 1 : (b >> 5) == 0x6 && b >= 0xc2 ? 2 : (b >> 4) == 0xe ? 3 : (b >> 3) == 0x1e && b <= 0xf4 ? 4 : 0;
      bool ok = len > 0 && i + static_cast<std::size_t>(len) <= line.size();
      for (int k = 1; ok && k < len; ++k) ok = (static_cast<unsigned char>(line[i + k]) & 0xc0) == 0x80;
      if (!ok) throw file_error("calibration", "parse", path.string(), n, "", "not UTF-8 text");
      i += static_cast<std::size_t>(len);
    }
    const std::size_t indent = line.find_first_not_of(' ');
    if (indent != std::string::npos && indent > 0 && line[indent] == '%') {
      throw file_error("calibration", "parse", path.string(), n, "", "a directive (%...) must start the line");
    }
    if (line.find('%') != std::string::npos && n > 1) {
      throw file_error("calibration", "parse", path.string(), n, "", "'%' only in the first line's directive");
    }
    // An indented marker ("   ---") is no marker to YAML, but OpenCV 4.6's parser loops forever
    // on one (found by fuzzing): refuse it.
    if (indent != std::string::npos && indent > 0 &&
        (line.compare(indent, 3, "---") == 0 || line.compare(indent, 3, "...") == 0)) {
      throw file_error("calibration", "parse", path.string(), n, "",
                       fmt::format("a document marker ({}) starts its line", line.substr(indent, 3)));
    }
    if (line.rfind("---", 0) == 0 || line.rfind("...", 0) == 0) {
      if (!indents.empty()) throw file_error("calibration", "parse", path.string(), n, "", "one YAML document per file");
      // OpenCV 4.6's parser can loop forever on content after a marker ("---L:0" found by
      // fuzzing); our files write the marker alone.
      if (line.find_first_not_of(" \r", 3) != std::string::npos)
        throw file_error("calibration", "parse", path.string(), n, "",
                         fmt::format("a document marker ({}) stands alone on its line", line.substr(0, 3)));
      continue;
    }
    if (indent == std::string::npos || line[indent] == '#' || line[indent] == '%') continue;
    if (flow > 0 && indent <= flow_indent) {
      throw file_error("calibration", "parse", path.string(), n, "", "unclosed [ or { above");
    }
    if (flow == 0) {
      flow_indent = indent;
      if (indents.empty()) {
        indents.push_back(indent);  // the document's first level
      } else if (indent < indents.front()) {
        throw file_error("calibration", "parse", path.string(), n, "", "indentation above the document's first level");
      } else {
        bool dedented = false;
        while (indents.back() > indent) indents.pop_back(), dedented = true;
        if (indents.back() < indent) {
          if (dedented) throw file_error("calibration", "parse", path.string(), n, "", "inconsistent indentation");
          indents.push_back(indent);
        }
      }
    }
    bool quoted = false;
    char quote = 0;
    for (std::size_t i = indent; i < line.size(); ++i) {
      const char c = line[i];
      if (quoted) {
        if (c == quote) quoted = false;
      } else if (c == '"' || c == '\'') {
        quoted = true, quote = c;
      } else if (c == '#' && i > 0 && line[i - 1] == ' ') {
        break;
      } else if (c == '[' || c == '{') {
        ++flow;
      } else if (c == ']' || c == '}') {
        flow = std::max(0, flow - 1);
      }
    }
  }
}

}  // namespace

RigCalibration read_calibration(const fs::path& path) {
  // OpenCV's parser can throw more than cv::Exception on malformed files (std::length_error
  // was found by fuzzing): every failure becomes one kumite::Error naming the file.
  try {
    return read_calibration_unchecked(path);
  } catch (const Error&) {
    throw;
  } catch (const cv::Exception& e) {
    throw file_error("calibration", "parse", path.string(), 0, "", "not valid: " + (e.err.empty() ? std::string(e.what()) : e.err));
  } catch (const std::exception& e) {
    throw file_error("calibration", "parse", path.string(), 0, "", std::string("not valid: ") + e.what());
  }
}

namespace {

RigCalibration read_calibration_unchecked(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    throw file_error("calibration", "missing", path.string(), 0, "", "no such file");
  }
  if (fs::is_directory(path, ec)) {
    throw file_error("calibration", "io", path.string(), 0, "", "is a folder, not a file: give the calibration .yaml");
  }
  // Read once for both checks (OpenCV reads the file itself).
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  check_yaml_text(path, text);
  check_yaml_parses(path, std::move(text));
  cv::FileStorage fsr;
  try {
    if (!fsr.open(path.string(), cv::FileStorage::READ)) {
      throw file_error("calibration", "parse", path.string(), 0, "", "cannot open or parse");
    }
  } catch (const cv::Exception& e) {
    std::string msg = e.err.empty() ? e.what() : e.err;
    throw file_error("calibration", "parse", path.string(), 0, "", "not valid YAML: " + msg);
  }
  const cv::FileNode cams = fsr["cameras"];
  if (cams.empty() || !cams.isSeq()) fail(path, "cameras", "missing or not a sequence");
  if (cams.size() == 0) fail(path, "cameras", "empty: no camera in the file");

  RigCalibration rig;
  std::set<std::string> names;
  int index = 0;
  for (const cv::FileNode& cam : cams) {
    std::string where = fmt::format("cameras[{}]", index++);
    if (!cam.isMap()) fail(path, where, "not a mapping");
    CameraCalibration c;
    if (cam["name"].empty() || !cam["name"].isString()) fail(path, where + ".name", "missing");
    c.name = static_cast<std::string>(cam["name"]);
    if (c.name.empty()) fail(path, where + ".name", "empty");
    where = fmt::format("cameras[{}] ({})", index - 1, c.name);
    if (!names.insert(c.name).second) fail(path, where + ".name", "duplicate camera name");
    c.image_width = read_positive_int(cam, "image_width", path, where);
    c.image_height = read_positive_int(cam, "image_height", path, where);
    cv::Mat K = read_matrix(cam, "camera_matrix", 3, 3, path, where);
    cv::Mat D = read_matrix(cam, "distortion_coefficients", 1, 5, path, where);
    cv::Mat R = read_matrix(cam, "rotation", 3, 3, path, where);
    cv::Mat t = read_matrix(cam, "translation", 3, 1, path, where);
    c.camera_matrix = cv::Matx33d(K);
    for (int i = 0; i < 5; ++i) c.distortion[i] = D.at<double>(i);
    c.rotation = cv::Matx33d(R);
    c.translation = cv::Vec3d(t.at<double>(0), t.at<double>(1), t.at<double>(2));
    if (c.camera_matrix(0, 0) <= 0 || c.camera_matrix(1, 1) <= 0 || c.camera_matrix(2, 2) != 1.0) {
      fail(path, where + ".camera_matrix", "focal lengths must be positive and K[2][2] = 1");
    }
    const cv::Matx33d RtR = c.rotation.t() * c.rotation;
    const double orth = cv::norm(RtR - cv::Matx33d::eye(), cv::NORM_INF);
    if (orth > 1e-6 || cv::determinant(c.rotation) < 0) {
      fail(path, where + ".rotation",
           fmt::format("not a rotation (|R^T R - I| = {:.2g}, det = {:.4f})", orth,
                       cv::determinant(c.rotation)));
    }
    if (const cv::FileNode rms = cam["rms_px"]; !rms.empty()) {
      if (!rms.isReal() && !rms.isInt()) fail(path, where + ".rms_px", "must be a number");
      const double v = static_cast<double>(rms);
      if (!std::isfinite(v)) fail_nonfinite(path, where + ".rms_px");
      if (v < 0) fail(path, where + ".rms_px", "must be >= 0");
      c.rms_px = v;
    }
    if (!cam["per_view_errors_px"].empty()) {
      cv::Mat e;
      check_matrix_size(cam["per_view_errors_px"], path, where + ".per_view_errors_px");
      try {
        cam["per_view_errors_px"] >> e;
      } catch (const cv::Exception&) {
        fail(path, where + ".per_view_errors_px", "not a matrix");
      }
      e.convertTo(e, CV_64F);
      c.per_view_errors_px.assign(e.begin<double>(), e.end<double>());
      for (const double v : c.per_view_errors_px) {
        if (!std::isfinite(v)) fail_nonfinite(path, where + ".per_view_errors_px");
        // -1: a view in which the camera did not see the board (what the calibration tools write).
        if (v < 0 && v != -1.0) fail(path, where + ".per_view_errors_px", "must be >= 0 (or -1: board not seen)");
      }
    }
    rig.cameras.push_back(std::move(c));
  }
  return rig;
}

}  // namespace

void write_calibration(const fs::path& path, const RigCalibration& rig) {
  const fs::path tmp = temporary_path_beside(path.extension() == ".yml" || path.extension() == ".yaml"
                                                 ? path
                                                 : fs::path(path.string() + ".yaml"));
  {
    cv::FileStorage out(tmp.string(), cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    if (!out.isOpened()) {
      throw Error("io", "open", fmt::format("{}: cannot write", path.string()));
    }
    out.writeComment(
        "Kumite rig calibration. x_cam = R * x_room + t; metres; room frame +Y up, "
        "floor y = 0, front wall toward -Z.");
    out << "cameras" << "[";
    for (const auto& c : rig.cameras) {
      out << "{";
      out << "name" << c.name;
      out << "image_width" << c.image_width << "image_height" << c.image_height;
      out << "camera_matrix" << cv::Mat(c.camera_matrix);
      out << "distortion_coefficients" << cv::Mat(c.distortion).reshape(1, 1);
      out << "rotation" << cv::Mat(c.rotation);
      out << "translation" << cv::Mat(c.translation);
      if (c.rms_px) out << "rms_px" << *c.rms_px;
      if (!c.per_view_errors_px.empty()) {
        out << "per_view_errors_px" << cv::Mat(c.per_view_errors_px).reshape(1, 1);
      }
      out << "}";
    }
    out << "]";
    out.release();
  }
  commit_temporary(tmp, path);
}

}  // namespace kumite::tracking
