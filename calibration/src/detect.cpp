#include "kumite/calibration/detect.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

extern "C" {
#include <apriltag.h>
#include <common/image_u8.h>
#include <tag36h11.h>
}

#include "kumite/calibration/tag_quads.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/recording.hpp"

namespace kumite::calibration {

struct BoardDetector::Impl {
  apriltag_family_t* family = nullptr;
  apriltag_detector_t* detector = nullptr;
  /// Full resolution without edge refinement: corners re-fitted by fit_tag_quads() on the
  /// image the library segmented, which we then blur ourselves (blur_sigma, px).
  bool refit = false;
  float blur_sigma = 0;
  QuadFitParams quad_params;
  ~Impl() {
    if (detector) apriltag_detector_destroy(detector);
    if (family) tag36h11_destroy(family);
  }
};

DetectorOptions technician_detector() {
  DetectorOptions o;
  o.quad_decimate = 1.f;
  o.refine_edges = false;  // apriltag's own corners are sub-pixel at full resolution
  return o;
}

BoardDetector::BoardDetector(const Board& board, const DetectorOptions& options)
    : board_(board), options_(options), impl_(std::make_unique<Impl>()) {
  validate(board);
  impl_->family = tag36h11_create();
  impl_->detector = apriltag_detector_create();
  apriltag_detector_add_family_bits(impl_->detector, impl_->family, std::max(options.max_hamming, 0));
  impl_->detector->quad_decimate = options.quad_decimate;
  impl_->detector->quad_sigma = options.quad_sigma;
  impl_->detector->refine_edges = options.refine_edges;
  impl_->detector->nthreads = std::max(1, options.threads);
  impl_->refit =
      options.refit_corners && options.quad_decimate == 1.f && !options.refine_edges && options.quad_sigma >= 0.f;
  if (impl_->refit) {
    // We blur, so that the library and fit_tag_quads() see the same image.
    impl_->blur_sigma = options.quad_sigma;
    impl_->detector->quad_sigma = 0;
    const auto& q = impl_->detector->qtp;
    QuadFitParams& p = impl_->quad_params;
    p.min_white_black_diff = q.min_white_black_diff;
    p.min_cluster_pixels = q.min_cluster_pixels;
    p.max_nmaxima = q.max_nmaxima;
    p.cos_critical_rad = q.cos_critical_rad;
    p.max_line_fit_mse = q.max_line_fit_mse;
    p.min_tag_width = std::max(3, impl_->family->width_at_border);  // over quad_decimate, 1 here
  }
}

namespace {

/// apriltag's blur before segmentation: a Gaussian of sigma px over 4 sigma (odd) pixels.
void apriltag_blur(cv::Mat& grey, float sigma) {
  int ksz = static_cast<int>(4 * sigma);
  if ((ksz & 1) == 0) ++ksz;
  if (ksz <= 1) return;
  image_u8_t im{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), grey.data};
  image_u8_gaussian_blur(&im, sigma, ksz);
}

/// Our re-fitted quad for a detection: the quad whose corners, in some rotation, lie within
/// kSameQuad_px of the library's. Returns false when there is none.
bool refitted_corners(const std::vector<TagQuad>& quads, const apriltag_detection_t& d, std::array<cv::Point2d, 4>& out) {
  constexpr double kSameQuad_px = 1.0;  // the duplicates move a corner by ~0.1 px
  double best = kSameQuad_px;
  bool found = false;
  // The decoded corners start at the tag's own corner and may wind the other way round.
  for (const auto& q : quads) {
    for (int shift = 0; shift < 4; ++shift) {
      for (int step : {1, 3}) {
        double worst = 0;
        for (int k = 0; k < 4; ++k) {
          const cv::Point2d& p = q.p[static_cast<std::size_t>((shift + step * k) & 3)];
          worst = std::max(worst, std::hypot(p.x - d.p[k][0], p.y - d.p[k][1]));
        }
        if (worst < best) {
          best = worst;
          found = true;
          for (int k = 0; k < 4; ++k) out[static_cast<std::size_t>(k)] = q.p[static_cast<std::size_t>((shift + step * k) & 3)];
        }
      }
    }
  }
  return found;
}

}  // namespace

BoardDetector::~BoardDetector() = default;

std::vector<TagCorners> BoardDetector::detect_tags(const cv::Mat& grey_in) {
  if (grey_in.type() != CV_8U) throw Error("calibration", "image", "detect_tags needs an 8-bit grey image");
  // apriltag 3.3 blurs (quad_sigma) the image it is given in place when it does not decimate
  // (and then decodes and refines edges on the blurred image): hand it a copy, or the caller's
  // image would come back blurred, once more on every call.
  cv::Mat grey = grey_in;
  if (impl_->detector->quad_decimate <= 1.f && impl_->detector->quad_sigma != 0.f) grey = grey_in.clone();
  if (impl_->refit && impl_->blur_sigma > 0.f) {
    grey = grey_in.clone();
    apriltag_blur(grey, impl_->blur_sigma);
  }
  image_u8_t im{grey.cols, grey.rows, static_cast<int32_t>(grey.step[0]), grey.data};
  zarray_t* dets = apriltag_detector_detect(impl_->detector, &im);
  std::vector<TagQuad> quads;
  if (impl_->refit && zarray_size(dets) > 0) {
    std::vector<cv::Rect2d> near;
    for (int i = 0; i < zarray_size(dets); ++i) {
      apriltag_detection_t* d = nullptr;
      zarray_get(dets, i, &d);
      double x0 = d->p[0][0], x1 = x0, y0 = d->p[0][1], y1 = y0;
      for (const auto& p : d->p) x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
      near.emplace_back(x0 - 2, y0 - 2, x1 - x0 + 4, y1 - y0 + 4);
    }
    quads = fit_tag_quads(grey, impl_->quad_params, &near);
  }
  std::vector<TagCorners> out;
  out.reserve(static_cast<std::size_t>(zarray_size(dets)));
  int not_refitted = 0;
  for (int i = 0; i < zarray_size(dets); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(dets, i, &d);
    if (d->hamming > options_.max_hamming) continue;
    TagCorners t;
    t.id = d->id;
    t.hamming = d->hamming;
    t.decision_margin = d->decision_margin;
    std::array<cv::Point2d, 4> p;
    for (int k = 0; k < 4; ++k) p[static_cast<std::size_t>(k)] = {d->p[k][0], d->p[k][1]};
    if (impl_->refit) {
      t.refitted = refitted_corners(quads, *d, p);
      if (!t.refitted) ++not_refitted;
    }
    // apriltag puts pixel centres at +0.5; OpenCV at integers.
    for (std::size_t k = 0; k < 4; ++k) t.corners[k] = p[k] - cv::Point2d(0.5, 0.5);
    out.push_back(t);
  }
  if (not_refitted > 0) {
    // Not expected (every decoded quad is one of ours, give or take a duplicate point); the
    // library's own corners are kept for those tags.
    spdlog::debug("{} of {} tags kept apriltag's own corners: no re-fitted quad within 1 px", not_refitted,
                  out.size());
  }
  apriltag_detections_destroy(dets);
  return out;
}

namespace {

BoardDetection detect_chessboard(const Board& board, const cv::Mat& grey) {
  BoardDetection det;
  std::vector<cv::Point2f> corners;
  const cv::Size pattern(board.cols, board.rows);
  const int flags = cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  if (!cv::findChessboardCorners(grey, pattern, corners, flags)) return det;
  cv::cornerSubPix(grey, corners, cv::Size(11, 11), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.01));
  const auto obj = board.corner_points();
  for (int i = 0; i < static_cast<int>(corners.size()); ++i) {
    det.corner_ids.push_back(i);
    det.image_points.push_back(corners[static_cast<std::size_t>(i)]);
    det.object_points.push_back(obj[static_cast<std::size_t>(i)]);
  }
  return det;
}

}  // namespace

BoardDetection BoardDetector::detect(const cv::Mat& image) {
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = image;
  }
  if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U);
  if (board_.type == BoardType::chessboard) return detect_chessboard(board_, grey);

  BoardDetection det;
  const auto tags = detect_tags(grey);
  std::vector<bool> seen(static_cast<std::size_t>(board_.rows * board_.cols), false);
  int count = 0;
  for (const auto& t : tags) {
    const int idx = board_.tag_index(t.id);
    if (idx < 0 || seen[static_cast<std::size_t>(idx)]) continue;  // not ours, or a duplicate
    seen[static_cast<std::size_t>(idx)] = true;
    ++count;
    // apriltag p[0..3]: bottom-left, bottom-right, top-right, top-left of the tag as printed;
    // our corner k: 0 top-left, 1 top-right, 2 bottom-right, 3 bottom-left.
    for (int p = 0; p < 4; ++p) {
      const int id = idx * 4 + (3 - p);
      const cv::Point3d o = board_.corner_point(id);
      det.corner_ids.push_back(id);
      det.image_points.emplace_back(static_cast<float>(t.corners[static_cast<std::size_t>(p)].x),
                                    static_cast<float>(t.corners[static_cast<std::size_t>(p)].y));
      det.object_points.emplace_back(static_cast<float>(o.x), static_cast<float>(o.y), 0.f);
    }
  }
  if (count < options_.min_tags) return {};
  return det;
}

cv::Mat read_image_grey(const std::filesystem::path& path) {
  std::string why;
  cv::Mat img = tracking::read_grey_image(path, why);
  if (img.empty())
    throw file_error("calibration", "image", path.string(), 0, "",
                     fmt::format("cannot read this image ({}): re-export or re-capture it", why));
  return img;
}

}  // namespace kumite::calibration
