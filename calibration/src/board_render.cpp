// Board rendering (PNG raster, SVG) from the apriltag library's own tag bitmaps.
#include <cmath>
#include <memory>

#include <fmt/format.h>
#include <opencv2/core.hpp>

extern "C" {
#include <apriltag.h>
#include <tag36h11.h>
}

#include "kumite/calibration/board.hpp"
#include "kumite/common/error.hpp"

namespace kumite::calibration {
namespace {

struct FamilyDeleter {
  void operator()(apriltag_family_t* f) const { tag36h11_destroy(f); }
};

/// The black square's bits (width_at_border^2, row-major, 1 = white) of one tag.
std::vector<unsigned char> tag_black_square(apriltag_family_t* fam, int id) {
  image_u8_t* im = apriltag_to_image(fam, id);
  const int w = fam->width_at_border;
  const int off = (fam->total_width - w) / 2;
  std::vector<unsigned char> bits(static_cast<std::size_t>(w * w));
  for (int y = 0; y < w; ++y) {
    for (int x = 0; x < w; ++x) {
      bits[static_cast<std::size_t>(y * w + x)] = im->buf[(y + off) * im->stride + x + off] > 127 ? 1 : 0;
    }
  }
  image_u8_destroy(im);
  return bits;
}

}  // namespace

BoardPattern::BoardPattern(const Board& board) : board_(board) {
  validate(board);
  if (board.type == BoardType::apriltag_grid) {
    std::unique_ptr<apriltag_family_t, FamilyDeleter> fam(tag36h11_create());
    cells_ = fam->width_at_border;
    for (int i = 0; i < board.rows * board.cols; ++i) {
      tag_bits_.push_back(tag_black_square(fam.get(), board.first_id + i));
    }
  }
}

float BoardPattern::operator()(double x, double y) const {
  const Board& b = board_;
  if (b.type == BoardType::chessboard) {
    const double s = b.square_size_m;
    const double i = std::floor((x + s) / s), j = std::floor((y + s) / s);
    if (i < 0 || j < 0 || i > b.cols || j > b.rows) return 1.f;
    return (static_cast<long>(i + j) % 2 == 0) ? 0.f : 1.f;
  }
  const double pitch = b.tag_size_m + b.gap_m;
  const double c = std::floor(x / pitch), r = std::floor(y / pitch);
  if (c < 0 || r < 0 || c >= b.cols || r >= b.rows) return 1.f;
  const double lx = x - c * pitch, ly = y - r * pitch;
  if (lx >= b.tag_size_m || ly >= b.tag_size_m) return 1.f;
  const int cx = std::min(cells_ - 1, static_cast<int>(lx / b.tag_size_m * cells_));
  const int cy = std::min(cells_ - 1, static_cast<int>(ly / b.tag_size_m * cells_));
  const auto& bits = tag_bits_[static_cast<std::size_t>(r * b.cols + c)];
  return bits[static_cast<std::size_t>(cy * cells_ + cx)] ? 1.f : 0.f;
}

cv::Mat render_board(const Board& board, double px_per_m, double margin_m) {
  const BoardPattern pattern(board);
  const cv::Rect2d ext = board.pattern_extent();
  const int w = static_cast<int>(std::lround((ext.width + 2 * margin_m) * px_per_m));
  const int h = static_cast<int>(std::lround((ext.height + 2 * margin_m) * px_per_m));
  if (w <= 0 || h <= 0 || static_cast<double>(w) * h > 4e8) {
    throw Error("calibration", "board", fmt::format("board image of {}x{} px is not sensible: check the DPI", w, h));
  }
  cv::Mat img(h, w, CV_8U);
  const double x0 = ext.x - margin_m, y0 = ext.y - margin_m;
  cv::parallel_for_(cv::Range(0, h), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      auto* out = img.ptr<unsigned char>(v);
      for (int u = 0; u < w; ++u) {
        float sum = 0.f;
        for (int sy = 0; sy < 2; ++sy) {
          for (int sx = 0; sx < 2; ++sx) {
            sum += pattern(x0 + (u + 0.25 + 0.5 * sx) / px_per_m, y0 + (v + 0.25 + 0.5 * sy) / px_per_m);
          }
        }
        out[u] = static_cast<unsigned char>(std::lround(sum * 255.f / 4.f));
      }
    }
  });
  return img;
}

std::string board_svg(const Board& board, double margin_m) {
  const cv::Rect2d ext = board.pattern_extent();
  const double mm = 1000.0;
  const double w = (ext.width + 2 * margin_m) * mm, h = (ext.height + 2 * margin_m) * mm;
  const double ox = (margin_m - ext.x) * mm, oy = (margin_m - ext.y) * mm;  // board origin
  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0:.4f}mm\" height=\"{1:.4f}mm\" "
      "viewBox=\"0 0 {0:.4f} {1:.4f}\" shape-rendering=\"crispEdges\">\n"
      "<!-- Kumite calibration board: print at 100 % (no fit-to-page). Units: mm. -->\n"
      "<rect x=\"0\" y=\"0\" width=\"{0:.4f}\" height=\"{1:.4f}\" fill=\"white\"/>\n<g fill=\"black\">\n",
      w, h);
  auto rect = [&](double x, double y, double rw, double rh) {
    out += fmt::format("<rect x=\"{:.4f}\" y=\"{:.4f}\" width=\"{:.4f}\" height=\"{:.4f}\"/>\n",
                       ox + x * mm, oy + y * mm, rw * mm, rh * mm);
  };
  if (board.type == BoardType::chessboard) {
    const double s = board.square_size_m;
    for (int j = 0; j <= board.rows; ++j) {
      for (int i = 0; i <= board.cols; ++i) {
        if ((i + j) % 2 == 0) rect((i - 1) * s, (j - 1) * s, s, s);
      }
    }
  } else {
    const BoardPattern pattern(board);
    const double cell = board.tag_size_m / 8.0, pitch = board.tag_size_m + board.gap_m;
    for (int r = 0; r < board.rows; ++r) {
      for (int c = 0; c < board.cols; ++c) {
        for (int cy = 0; cy < 8; ++cy) {
          // Merge runs of black cells along the row to keep the file small.
          int run = -1;
          for (int cx = 0; cx <= 8; ++cx) {
            const bool black = cx < 8 && pattern(c * pitch + (cx + 0.5) * cell, r * pitch + (cy + 0.5) * cell) < 0.5f;
            if (black && run < 0) run = cx;
            if (!black && run >= 0) {
              rect(c * pitch + run * cell, r * pitch + cy * cell, (cx - run) * cell, cell);
              run = -1;
            }
          }
        }
      }
    }
  }
  out += "</g>\n</svg>\n";
  return out;
}

}  // namespace kumite::calibration
