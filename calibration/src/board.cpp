// Board geometry, board.toml and the floor-points file (the one toml++ translation unit of
// this library).
#include "kumite/calibration/board.hpp"

#include <cmath>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/common/error.hpp"

namespace kumite::calibration {
namespace {

[[noreturn]] void fail(const std::string& source, int line, const std::string& key,
                       const std::string& msg) {
  throw file_error("calibration", "board", source, line, key, msg);
}

int line_of(const toml::node& n) { return static_cast<int>(n.source().begin.line); }

}  // namespace

int Board::corner_count() const {
  return type == BoardType::apriltag_grid ? rows * cols * 4 : rows * cols;
}

cv::Point3d Board::corner_point(int corner_id) const {
  if (type == BoardType::chessboard) {
    const int r = corner_id / cols, c = corner_id % cols;
    return {c * square_size_m, r * square_size_m, 0.0};
  }
  const int tag = corner_id / 4, k = corner_id % 4;
  const int r = tag / cols, c = tag % cols;
  const double pitch = tag_size_m + gap_m;
  const double x0 = c * pitch, y0 = r * pitch;
  // k: 0 top-left, 1 top-right, 2 bottom-right, 3 bottom-left.
  const double dx = (k == 1 || k == 2) ? tag_size_m : 0.0;
  const double dy = (k == 2 || k == 3) ? tag_size_m : 0.0;
  return {x0 + dx, y0 + dy, 0.0};
}

std::vector<cv::Point3f> Board::corner_points() const {
  std::vector<cv::Point3f> pts(static_cast<std::size_t>(corner_count()));
  for (int i = 0; i < corner_count(); ++i) {
    const cv::Point3d p = corner_point(i);
    pts[static_cast<std::size_t>(i)] = cv::Point3f(static_cast<float>(p.x), static_cast<float>(p.y), 0.f);
  }
  return pts;
}

cv::Rect2d Board::pattern_extent() const {
  if (type == BoardType::chessboard) {
    return {-square_size_m, -square_size_m, (cols + 1) * square_size_m,
            (rows + 1) * square_size_m};
  }
  return {0.0, 0.0, cols * tag_size_m + (cols - 1) * gap_m,
          rows * tag_size_m + (rows - 1) * gap_m};
}

double Board::default_margin_m() const {
  // The detector needs a white quiet zone around the outer black squares: two bit cells for
  // tags, one square for a chessboard.
  if (type == BoardType::chessboard) return square_size_m;
  return std::max(gap_m, 2.0 * tag_size_m / 8.0);
}

int Board::tag_index(int tag_id) const {
  const int i = tag_id - first_id;
  return (i >= 0 && i < rows * cols) ? i : -1;
}

namespace {
using LineOf = std::function<int(const char*)>;
void validate_impl(const Board& b, const std::string& source, const LineOf& line_fn) {
  auto fail = [&](const std::string& src, int, const char* key, const std::string& msg) {
    calibration::fail(src, line_fn ? line_fn(key) : 0, key, msg);
  };
  if (b.rows < 1 || b.rows > 200) fail(source, 0, "rows", "must be between 1 and 200");
  if (b.cols < 1 || b.cols > 200) fail(source, 0, "cols", "must be between 1 and 200");
  if (b.type == BoardType::chessboard) {
    if (b.rows < 2 || b.cols < 2) fail(source, 0, "rows", "a chessboard needs at least 2x2 inner corners");
    if (b.rows == b.cols) {
      fail(source, 0, "cols",
           "rows == cols: a square chessboard's orientation is ambiguous; use e.g. 6 x 9 inner corners");
    }
    if (!(b.square_size_m > 0 && b.square_size_m < 1)) {
      fail(source, 0, "square_size_m", "must be > 0 and < 1 (metres)");
    }
    return;
  }
  if (b.family != "tag36h11") fail(source, 0, "family", "only \"tag36h11\" is supported");
  if (!(b.tag_size_m > 0 && b.tag_size_m < 2)) fail(source, 0, "tag_size_m", "must be > 0 and < 2 (metres)");
  if (!(b.gap_m >= 0 && b.gap_m < 2)) fail(source, 0, "gap_m", "must be >= 0 and < 2 (metres)");
  if (b.gap_m > 0 && b.gap_m < b.tag_size_m / 8.0) {
    fail(source, 0, "gap_m",
         "must be at least one tag bit (tag_size_m / 8) so neighbouring tags stay separable");
  }
  if (b.first_id < 0 || b.first_id + b.rows * b.cols > 587) {
    fail(source, 0, "first_id", "tag36h11 has ids 0..586: first_id + rows*cols must be <= 587");
  }
}
}  // namespace

void validate(const Board& b, const std::string& source) { validate_impl(b, source, {}); }

Board parse_board(std::string_view text, const std::string& source) {
  toml::table tbl;
  try {
    tbl = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    fail(source, static_cast<int>(e.source().begin.line), "", std::string(e.description()));
  }
  static const char* known[] = {"type", "family", "rows", "cols", "tag_size_m",
                                "gap_m", "first_id", "square_size_m"};
  for (const auto& [k, v] : tbl) {
    bool ok = false;
    for (const char* n : known) ok = ok || k.str() == n;
    if (!ok) fail(source, line_of(v), std::string(k.str()), "unknown key");
  }
  Board b;
  auto get_string = [&](const char* key, bool required) -> std::optional<std::string> {
    const toml::node* n = tbl.get(key);
    if (!n) {
      if (required) fail(source, 0, key, "missing");
      return std::nullopt;
    }
    if (!n->is_string()) fail(source, line_of(*n), key, "must be a string");
    return n->value<std::string>();
  };
  auto get_int = [&](const char* key, bool required, int def) -> int {
    const toml::node* n = tbl.get(key);
    if (!n) {
      if (required) fail(source, 0, key, "missing");
      return def;
    }
    if (!n->is_integer()) fail(source, line_of(*n), key, "must be an integer");
    const int64_t v = *n->value<int64_t>();
    if (v < -1000000 || v > 1000000) fail(source, line_of(*n), key, "out of range");
    return static_cast<int>(v);
  };
  auto get_double = [&](const char* key, bool required, double def) -> double {
    const toml::node* n = tbl.get(key);
    if (!n) {
      if (required) fail(source, 0, key, "missing");
      return def;
    }
    if (!n->is_number()) fail(source, line_of(*n), key, "must be a number (metres)");
    const double v = *n->value<double>();
    if (!std::isfinite(v)) fail(source, line_of(*n), key, "must be a finite number (metres)");
    // -0 is 0 (found by fuzz_board: "gap_m = -0.0" was written back as "-0", read as 0).
    return v + 0.0;
  };
  const std::string type = *get_string("type", true);
  if (type == "apriltag_grid") {
    b.type = BoardType::apriltag_grid;
  } else if (type == "chessboard") {
    b.type = BoardType::chessboard;
  } else {
    fail(source, line_of(*tbl.get("type")), "type", "must be \"apriltag_grid\" or \"chessboard\"");
  }
  b.rows = get_int("rows", true, 0);
  b.cols = get_int("cols", true, 0);
  if (b.type == BoardType::apriltag_grid) {
    b.family = get_string("family", false).value_or("tag36h11");
    b.tag_size_m = get_double("tag_size_m", true, 0);
    b.gap_m = get_double("gap_m", true, 0);
    b.first_id = get_int("first_id", false, 0);
  } else {
    b.square_size_m = get_double("square_size_m", true, 0);
  }
  validate_impl(b, source, [&](const char* key) {
    const toml::node* n = tbl.get(key);
    return n ? line_of(*n) : 0;
  });
  return b;
}

Board read_board(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) fail(path.string(), 0, "", "is a folder, not a file: give the board's .toml file");
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), 0, "", "cannot open the board file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_board(ss.str(), path.string());
}

std::string board_to_toml(const Board& b) {
  if (b.type == BoardType::chessboard) {
    return fmt::format(
        "# Kumite calibration board (kumite-calibrate board). Measure the printed squares and\n"
        "# correct square_size_m if the printer scaled the page.\n"
        "type = \"chessboard\"\n"
        "rows = {}                # inner corners down the board\n"
        "cols = {}                # inner corners along a row\n"
        "square_size_m = {:.6g}   # square edge, metres\n",
        b.rows, b.cols, b.square_size_m);
  }
  return fmt::format(
      "# Kumite calibration board (kumite-calibrate board). Measure the printed black squares\n"
      "# and correct tag_size_m / gap_m if the printer scaled the page.\n"
      "type = \"apriltag_grid\"\n"
      "family = \"{}\"\n"
      "rows = {}                # tags down the board\n"
      "cols = {}                # tags along a row\n"
      "tag_size_m = {:.6g}      # black square edge, metres\n"
      "gap_m = {:.6g}           # white space between neighbouring tags, metres\n"
      "first_id = {}            # id of the top-left tag; id = first_id + row*cols + col\n",
      b.family, b.rows, b.cols, b.tag_size_m, b.gap_m, b.first_id);
}

std::vector<FloorPoint> read_floor_points(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), 0, "", "cannot open the floor points file");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string src = path.string();
  toml::table tbl;
  try {
    tbl = toml::parse(ss.str(), src);
  } catch (const toml::parse_error& e) {
    fail(src, static_cast<int>(e.source().begin.line), "", std::string(e.description()));
  }
  const toml::array* arr = tbl["points"].as_array();
  if (!arr) fail(src, 0, "points", "missing: expected [[points]] tables with room = [x, y, z] and pixels = { cam = [u, v] }");
  std::vector<FloorPoint> out;
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const toml::table* t = (*arr)[i].as_table();
    const std::string key = fmt::format("points[{}]", i);
    if (!t) fail(src, line_of((*arr)[i]), key, "must be a table");
    FloorPoint p;
    p.line = line_of(*t);
    const toml::array* room = (*t)["room"].as_array();
    if (!room || room->size() != 3) fail(src, p.line, key + ".room", "must be [x, y, z] in metres");
    for (std::size_t k = 0; k < 3; ++k) {
      const auto v = (*room)[k].value<double>();
      if (!v) fail(src, line_of((*room)[k]), key + ".room", "must be numbers (metres)");
      p.room[static_cast<int>(k)] = *v;
    }
    const toml::table* px = (*t)["pixels"].as_table();
    if (!px) fail(src, p.line, key + ".pixels", "missing: { cam0 = [u, v], cam1 = [u, v] }");
    for (const auto& [cam, node] : *px) {
      const toml::array* uv = node.as_array();
      const std::string k2 = key + ".pixels." + std::string(cam.str());
      if (!uv || uv->size() != 2) fail(src, line_of(node), k2, "must be [u, v] in pixels");
      const auto u = (*uv)[0].value<double>(), v = (*uv)[1].value<double>();
      if (!u || !v) fail(src, line_of(node), k2, "must be numbers (pixels)");
      p.pixels.emplace_back(std::string(cam.str()), cv::Point2d(*u, *v));
    }
    if (p.pixels.size() < 2) fail(src, p.line, key + ".pixels", "a point needs pixels in at least two cameras");
    out.push_back(std::move(p));
  }
  if (out.size() < 3) fail(src, 0, "points", fmt::format("{} points given: mark at least three floor points", out.size()));
  return out;
}

}  // namespace kumite::calibration
