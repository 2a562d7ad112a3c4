#pragma once
// Tag quads from a grey image, found the way the apriltag library finds them, without the
// duplicate edge points of Debian's apriltag 3.3.0.
//
// Why this exists: apriltag segments the image (adaptive threshold, connected components),
// collects the points half-way between black and white neighbours of each pair of components,
// sorts them by angle around their centre and fits four lines to them. In 3.3.0 the two
// diagonal neighbour pairs of a 2x2 block that straddles an edge produce the same half-way
// point twice; duplicates were removed only where the angle sort left them side by side, and
// the float angle key ties often, so some edges were fitted with doubled points. Upstream fixed
// this after 3.3.0 (a point is not added twice; apriltag pull request 308). Its own test
// corners were regenerated with the fix, and on two of its 47 test tags 3.3.0 is off them by
// 0.106 and 0.140 px. BoardDetector (detect.hpp) therefore lets the library find and decode the
// tags, then re-fits each tag's corners here.
//
// The fitting follows the library's published algorithm step for step (same thresholds, same
// order of points, same float/double arithmetic and sort), so that a quad comes out identical
// to the library's wherever no duplicate point was involved: tests/calibration checks this
// against the library itself (keep_diagonal_duplicates) and the upstream corners to 4 decimals.
//
// Coordinates follow apriltag's convention (pixel centres at +0.5), corners in the library's
// quad order. Only the full-resolution path is covered (no decimation, no edge refinement).
#include <array>
#include <vector>

#include <opencv2/core.hpp>

namespace kumite::calibration {

/// The apriltag library's quad thresholds (apriltag_quad_thresh_params), same meaning.
struct QuadFitParams {
  int min_white_black_diff = 5;    ///< grey levels: less contrast in a 12x12 px window: no edge
  int min_cluster_pixels = 5;      ///< edge points: smaller clusters are skipped
  int max_nmaxima = 10;            ///< corner candidates kept per cluster
  float cos_critical_rad = 0.98480775f;  ///< cos of the smallest corner angle allowed (10 deg)
  float max_line_fit_mse = 10.f;   ///< px^2: worst mean squared distance of an edge's points to its line
  int min_tag_width = 8;           ///< px: tag36h11's width at its border (8), over decimation
  /// Reproduces apriltag 3.3.0's duplicate diagonal points (for tests against the library).
  bool keep_diagonal_duplicates = false;
};

/// One quad: four corners (apriltag pixel convention, +0.5 px from OpenCV's; float precision,
/// as the library keeps them), in the order the library's quad fit gives them.
struct TagQuad {
  std::array<cv::Point2d, 4> p{};
};

/// All quads in a grey (CV_8U) image at full resolution. The image is the one the library
/// segments: with quad_sigma set, the blurred image (see BoardDetector::detect_tags). None in
/// an image under 8 px or from 32768 px on a side.
/// near: when given, only clusters of edge points whose bounding box meets one of these
/// rectangles (px) are fitted (the tags the library decoded; saves half the time).
std::vector<TagQuad> fit_tag_quads(const cv::Mat& grey, const QuadFitParams& params = {},
                                   const std::vector<cv::Rect2d>* near = nullptr);

}  // namespace kumite::calibration
