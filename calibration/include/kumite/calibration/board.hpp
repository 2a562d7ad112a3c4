#pragma once
// Calibration boards: an AprilTag grid (tag36h11) or a chessboard, as described by board.toml.
//
// Board frame (OpenCV's chessboard convention): metres, origin at the top-left outer corner of
// the black square of tag (row 0, col 0) (chessboard: the first inner corner), +X along a row
// (to the right on the print), +Y down the columns, +Z into the board.
// Tag id = first_id + row * cols + col, row 0 at the top of the printed board.
//
// Corner ids: apriltag grid: 4 * (row * cols + col) + k with k = 0 top-left, 1 top-right,
// 2 bottom-right, 3 bottom-left of that tag's black square (as printed); chessboard:
// row * cols + col over the inner corners.
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace kumite::calibration {

enum class BoardType { apriltag_grid, chessboard };

struct Board {
  BoardType type = BoardType::apriltag_grid;
  std::string family = "tag36h11";  ///< apriltag_grid only (the only family supported now)
  int rows = 6;                      ///< tags (apriltag_grid) or inner corners (chessboard)
  int cols = 8;
  double tag_size_m = 0.04;     ///< m, black square edge (apriltag_grid)
  double gap_m = 0.012;         ///< m, white space between neighbouring tags (apriltag_grid)
  int first_id = 0;             ///< id of tag (0, 0)
  double square_size_m = 0.025; ///< m, chessboard square edge

  /// Number of corner ids (see the header comment).
  int corner_count() const;
  /// Board-frame position (m) of a corner id; z = 0.
  cv::Point3d corner_point(int corner_id) const;
  /// All corner positions, indexed by corner id.
  std::vector<cv::Point3f> corner_points() const;
  /// The printed pattern's extent (m): from the origin's top-left (chessboard: the outer
  /// squares' corner at (-square, -square)) to the bottom-right, without the white margin.
  cv::Rect2d pattern_extent() const;
  /// Default white margin around the pattern (m): the quiet zone the detector needs.
  double default_margin_m() const;
  /// Tag index (row * cols + col) for a detected tag id, or -1 when not on this board.
  int tag_index(int tag_id) const;
};

/// Checks ranges; throws kumite::Error naming `source` and the field at fault.
void validate(const Board& board, const std::string& source = "board");

/// Reads and validates board.toml. Errors name the file, line and key.
Board read_board(const std::filesystem::path& path);
/// Parses board TOML text (`source` names it in errors).
Board parse_board(std::string_view toml_text, const std::string& source);
/// The board.toml text for a board (comments included; parse_board reads it back).
std::string board_to_toml(const Board& board);

/// Greyscale rendering of the board (0 black, 255 white), `px_per_m` pixels per metre, with a
/// white `margin_m` around the pattern. 2x2 supersampled edges. Tag bitmaps come from the
/// apriltag library itself, so what is printed is what the detector decodes.
cv::Mat render_board(const Board& board, double px_per_m, double margin_m);

/// Board reflectance at a board-frame point (m): 0 black, 1 white (white outside the print).
/// Used by the synthetic renderer. Thread-safe.
class BoardPattern {
 public:
  explicit BoardPattern(const Board& board);
  float operator()(double x_m, double y_m) const;

 private:
  Board board_;
  std::vector<std::vector<unsigned char>> tag_bits_;  // per tag: 8x8 (width_at_border^2)
  int cells_ = 8;                                     // cells across the black square
};

/// SVG of the board with its exact physical size (mm units; print at 100 %).
std::string board_svg(const Board& board, double margin_m);

}  // namespace kumite::calibration
