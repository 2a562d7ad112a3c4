// Board geometry, board.toml and the floor-points file (read through the project's strict
// TOML reader, kumite/common/toml_reader.hpp).
#include "kumite/calibration/board.hpp"

#include <cmath>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>

#include <fmt/format.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"

namespace kumite::calibration {
namespace {

[[noreturn]] void fail(const std::string& source, int line, const std::string& key,
                       const std::string& msg) {
  throw file_error("calibration", "board", source, line, key, msg);
}


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
  const toml::table tbl = parse_toml(text, source, "calibration");
  const TomlTable t(tbl, "calibration", source);
  t.only({"type", "family", "rows", "cols", "tag_size_m", "gap_m", "first_id", "square_size_m"});
  Board b;
  const std::string type = t.string("type");
  if (type == "apriltag_grid") {
    b.type = BoardType::apriltag_grid;
  } else if (type == "chessboard") {
    b.type = BoardType::chessboard;
  } else {
    t.fail("value", "type", "must be \"apriltag_grid\" or \"chessboard\"");
  }
  // Ranges and their relations are checked by validate_impl below (one place for a board made
  // in code or read); here only the types, finiteness and a bound that keeps ints ints.
  b.rows = static_cast<int>(t.integer("rows", -1000000, 1000000));
  b.cols = static_cast<int>(t.integer("cols", -1000000, 1000000));
  // -0 is 0 (found by fuzz_board: "gap_m = -0.0" was written back as "-0", read as 0).
  const auto metres = [&](const char* key) { return t.number(key, TomlRange::any("m")) + 0.0; };
  if (b.type == BoardType::apriltag_grid) {
    b.family = t.opt_string("family").value_or("tag36h11");
    b.tag_size_m = metres("tag_size_m");
    b.gap_m = metres("gap_m");
    b.first_id = static_cast<int>(t.opt_integer("first_id", -1000000, 1000000).value_or(0));
  } else {
    b.square_size_m = metres("square_size_m");
  }
  validate_impl(b, source, [&](const char* key) { return t.has(key) ? t.line(key) : 0; });
  return b;
}

Board read_board(const std::filesystem::path& path) {
  return parse_board(read_text_file(path, "calibration"), path.string());
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
  const std::string src = path.string();
  const toml::table tbl = parse_toml(read_text_file(path, "calibration"), src, "calibration");
  const TomlTable top(tbl, "calibration", src);
  top.only({"points"});
  if (!top.has("points")) {
    top.fail("missing_key", "points",
             "is required: [[points]] tables with room = [x, y, z] and pixels = { cam = [u, v] }");
  }
  std::vector<FloorPoint> out;
  for (const TomlTable& t : top.tables("points")) {
    t.only({"room", "pixels"});
    FloorPoint p;
    p.line = t.line();
    const toml::node* room = t.raw().get("room");
    if (!room) t.fail("missing_key", "room", "is required: [x, y, z] in metres");
    if (!room->is_array() || room->as_array()->size() != 3) t.fail("type", "room", "must be [x, y, z] in metres");
    const auto xyz = *t.opt_numbers<3>("room", {-100, 100, "m"});
    p.room = cv::Vec3d(xyz[0], xyz[1], xyz[2]);
    const auto px = t.opt_table("pixels");
    if (!px) t.fail("missing_key", "pixels", "is required: { cam0 = [u, v], cam1 = [u, v] }");
    for (const auto& [cam, node] : px->raw()) {
      const std::string name(cam.str());
      if (!node.is_array() || node.as_array()->size() != 2) px->fail("type", name, "must be [u, v] in pixels");
      const auto uv = *px->opt_numbers<2>(name, {-1e6, 1e6, "px"});
      p.pixels.emplace_back(name, cv::Point2d(uv[0], uv[1]));
    }
    if (p.pixels.size() < 2) t.fail("value", "pixels", "a point needs pixels in at least two cameras");
    out.push_back(std::move(p));
  }
  if (out.size() < 3) top.fail("value", "points", fmt::format("{} points given: mark at least three floor points", out.size()));
  return out;
}

}  // namespace kumite::calibration
