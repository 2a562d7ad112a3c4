#pragma once
// Board detection in one image: the apriltag library for tag grids (partial views allowed),
// OpenCV's chessboard finder + cornerSubPix for chessboards. Image points use OpenCV's
// convention (pixel centres at integer coordinates); apriltag's +0.5 px offset is removed.
#include <array>
#include <filesystem>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/calibration/board.hpp"

namespace kumite::calibration {

struct DetectorOptions {
  float quad_decimate = 2.f;  ///< apriltag: quads found on an image decimated by this
  /// px, apriltag: Gaussian blur of the decimated image before segmentation. 0.8 px keeps
  /// sensor noise from splintering the segmentation: 3x faster on noisy 1280x720 views
  /// (bench/calibration), same corners (edges are refined on the unblurred image).
  float quad_sigma = 0.8f;
  /// apriltag: snap quad edges to image gradients at full resolution. Needed with decimation;
  /// it leaves a ~(-0.12, -0.12) px shift of the corners (its integer sampling). Without
  /// decimation it does more harm than good (see technician_detector()).
  bool refine_edges = true;
  /// Full resolution without edge refinement: re-fit each tag's corners without apriltag
  /// 3.3.0's duplicate edge points (tag_quads.hpp). Off: the library's corners as they come.
  bool refit_corners = true;
  int threads = 1;            ///< apriltag worker threads
  int max_hamming = 1;        ///< reject tags decoded with more bit errors than this
  int min_tags = 2;           ///< fewer tags in view: no board detection
};

/// What `kumite-calibrate` uses unless told otherwise (its --decimate, --blur, --refine-edges).
/// Offline calibration puts accuracy first: tags are found at full resolution (decimate 1),
/// which keeps the small, far and steeply tilted tags that carry the image corners and the
/// lens distortion (decimate 2 finds 14 of the 47 tags of apriltag's own test photos,
/// decimate 1 all of them), at ~3x the time per image. No edge refinement there: apriltag
/// 3.3's refine_edges samples whole pixels and, at decimate 1, runs on the blurred image; it
/// biases the corners (synthetic 4-camera set: positions 1-2 mm off and fx +0.06 % with it,
/// 0.2-0.8 mm and <= 0.02 % without).
DetectorOptions technician_detector();

/// One tag as the apriltag library decodes it (corners in its order: p[0] .. p[3], counter-
/// clockwise from the bottom-left), in OpenCV pixel coordinates.
struct TagCorners {
  int id = -1;
  std::array<cv::Point2d, 4> corners{};
  int hamming = 0;
  double decision_margin = 0;
  /// Corners re-fitted by fit_tag_quads() (tag_quads.hpp: without apriltag 3.3.0's duplicate
  /// edge points); false: the library's own (decimation or edge refinement on, or no match).
  bool refitted = false;
};

/// The board's corners found in one image (corner ids as in board.hpp).
struct BoardDetection {
  std::vector<int> corner_ids;
  std::vector<cv::Point2f> image_points;   ///< px, OpenCV convention
  std::vector<cv::Point3f> object_points;  ///< m, board frame
  bool empty() const { return corner_ids.empty(); }
  std::size_t size() const { return corner_ids.size(); }
};

class BoardDetector {
 public:
  explicit BoardDetector(const Board& board, const DetectorOptions& options = {});
  ~BoardDetector();
  BoardDetector(const BoardDetector&) = delete;
  BoardDetector& operator=(const BoardDetector&) = delete;

  /// Detects the board in a grey (CV_8U) or colour image. Not thread-safe (one per thread).
  BoardDetection detect(const cv::Mat& image);
  /// All tag36h11 tags in a grey image, whatever board they belong to.
  std::vector<TagCorners> detect_tags(const cv::Mat& grey);
  const Board& board() const { return board_; }

 private:
  struct Impl;
  Board board_;
  DetectorOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// Reads an image as 8-bit grey. Throws kumite::Error naming the file when unreadable.
cv::Mat read_image_grey(const std::filesystem::path& path);

}  // namespace kumite::calibration
