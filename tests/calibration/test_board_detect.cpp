// Board model, board.toml, rendering, and detection known answers.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <set>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag.h>
#include <common/image_u8.h>
#include <common/pjpeg.h>
#include <tag36h11.h>
// Not in apriltag's public header, but exported by libapriltag 3.3.0: the library's raw quad
// search, the oracle fit_tag_quads() is checked against (tests only).
zarray_t* apriltag_quad_thresh(apriltag_detector_t* td, image_u8_t* im);
}

#include "kumite/calibration/board.hpp"
#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/detect.hpp"
#include "kumite/calibration/tag_quads.hpp"
#include "kumite/common/error.hpp"

namespace fs = std::filesystem;
using namespace kumite::calibration;

namespace {
Board tag_board() {
  Board b;
  b.rows = 3;
  b.cols = 4;
  b.tag_size_m = 0.04;
  b.gap_m = 0.01;
  b.first_id = 5;
  return b;
}
}  // namespace

TEST(Board, GeometryFollowsTheIssueConvention) {
  const Board b = tag_board();
  EXPECT_EQ(b.corner_count(), 48);
  // Tag (row 1, col 2): id first_id + 1*4 + 2; its top-left corner at (2*0.05, 1*0.05).
  EXPECT_EQ(b.tag_index(5 + 6), 6);
  const cv::Point3d tl = b.corner_point(6 * 4 + 0), br = b.corner_point(6 * 4 + 2);
  EXPECT_NEAR(tl.x, 0.10, 1e-12);
  EXPECT_NEAR(tl.y, 0.05, 1e-12);
  EXPECT_NEAR(br.x, 0.14, 1e-12);
  EXPECT_NEAR(br.y, 0.09, 1e-12);
  EXPECT_EQ(b.tag_index(4), -1);
  EXPECT_EQ(b.tag_index(17), -1);
}

TEST(Board, TomlRoundTrip) {
  for (const Board& b : {tag_board(), [] {
         Board c;
         c.type = BoardType::chessboard;
         c.rows = 6;
         c.cols = 9;
         c.square_size_m = 0.025;
         return c;
       }()}) {
    const Board r = parse_board(board_to_toml(b), "rt.toml");
    EXPECT_EQ(r.type, b.type);
    EXPECT_EQ(r.rows, b.rows);
    EXPECT_EQ(r.cols, b.cols);
    EXPECT_EQ(r.corner_count(), b.corner_count());
    EXPECT_EQ(r.corner_point(r.corner_count() - 1), b.corner_point(b.corner_count() - 1));
  }
}

TEST(Board, TomlErrorsNameFileLineAndKey) {
  auto error_of = [](const std::string& text) {
    try {
      parse_board(text, "b.toml");
    } catch (const kumite::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("type = \"apriltag_grid\"\nrows = 6\ncols = 8\ntag_size_m = -0.04\ngap_m = 0.01\n"),
            "b.toml:4: tag_size_m: must be > 0 and < 2 (metres)");
  EXPECT_NE(error_of("type = \"apriltag_grid\"\nrows = 6\ncols = 8\ngap_m = 0.01\n").find("b.toml:1: tag_size_m: is required"),
            std::string::npos);
  EXPECT_NE(error_of("type = \"circles\"\n").find("b.toml:1: type:"), std::string::npos);
  EXPECT_NE(error_of("type = \"chessboard\"\nrows = 6\ncols = \"9\"\nsquare_size_m=0.02\n").find("b.toml:3: cols: must be an integer"),
            std::string::npos);
  EXPECT_NE(error_of("type = \"chessboard\"\nrows = 6\ncols = 9\nsquare_size_m=0.02\nsqare = 1\n").find("b.toml:5: sqare: unknown key"),
            std::string::npos);
  EXPECT_NE(error_of("type = [\n").find("b.toml:"), std::string::npos);
  EXPECT_NE(error_of("type = \"apriltag_grid\"\nrows = 30\ncols = 20\ntag_size_m = 0.04\ngap_m = 0.01\n").find("first_id"),
            std::string::npos);
}

TEST(Board, RenderedTagBoardIsDetectedWithTheRightCorners) {
  // A board printed at 2000 px/m, seen head-on: every corner must land where the board
  // geometry says (px = (X + margin) * scale - 0.5 in OpenCV's pixel-centre convention).
  const Board b = tag_board();
  const double scale = 2000, margin = 0.02;
  cv::Mat img = render_board(b, scale, margin);
  EXPECT_EQ(img.cols, static_cast<int>(std::lround((0.19 + 0.04) * scale)));
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.8);
  DetectorOptions opt;
  opt.quad_decimate = 1;
  BoardDetector det(b, opt);
  const BoardDetection d = det.detect(img);
  ASSERT_EQ(d.size(), 48u);
  // apriltag's edge refinement shifts every corner by about (-0.12, -0.12) px (see
  // detect.hpp); a wrong corner order or a missed +0.5 px would be off by >= 0.5 px.
  double sum2 = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const cv::Point3d o = b.corner_point(d.corner_ids[i]);
    const double ex = d.image_points[i].x - ((o.x + margin) * scale - 0.5);
    const double ey = d.image_points[i].y - ((o.y + margin) * scale - 0.5);
    EXPECT_LT(std::abs(ex), 0.25) << d.corner_ids[i];
    EXPECT_LT(std::abs(ey), 0.25) << d.corner_ids[i];
    sum2 += ex * ex + ey * ey;
  }
  EXPECT_LT(std::sqrt(sum2 / d.size()), 0.2);
}

TEST(Detect, ToolDefaultsLeaveTheImageAloneAndRepeat) {
  // apriltag 3.3 blurs (quad_sigma) an undecimated input in place; the detector must hand it a
  // copy, or every call would blur the caller's image once more until no tag is left.
  const Board b = tag_board();
  cv::Mat img = render_board(b, 2000, 0.02);
  const cv::Mat before = img.clone();
  BoardDetector det(b, technician_detector());
  std::size_t first = 0;
  for (int i = 0; i < 8; ++i) {
    const BoardDetection d = det.detect(img);
    if (i == 0) first = d.size();
    EXPECT_EQ(d.size(), first) << "call " << i;
  }
  EXPECT_EQ(first, 48u);
  EXPECT_EQ(cv::norm(img, before, cv::NORM_INF), 0.0);
}

TEST(Board, PartialViewStillDetected) {
  const Board b = tag_board();
  cv::Mat img = render_board(b, 2000, 0.02);
  cv::Mat half = img(cv::Rect(0, 0, img.cols / 2, img.rows)).clone();
  BoardDetector det(b);
  const BoardDetection d = det.detect(half);
  EXPECT_EQ(d.size(), 24u);
}

TEST(Board, RenderedChessboardIsFound) {
  Board b;
  b.type = BoardType::chessboard;
  b.rows = 6;
  b.cols = 9;
  b.square_size_m = 0.025;
  const double scale = 1600, margin = 0.03;
  cv::Mat img = render_board(b, scale, margin);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.8);
  BoardDetector det(b);
  const BoardDetection d = det.detect(img);
  ASSERT_EQ(d.size(), 54u);
  // Corner 0 at the first inner corner (origin): either end, as the chessboard is symmetric
  // under a half turn; check the spacing instead.
  const double step = cv::norm(d.image_points[1] - d.image_points[0]);
  EXPECT_NEAR(step, 0.025 * scale, 0.1);
}

TEST(Board, SvgHasExactPhysicalSize) {
  const Board b = tag_board();
  const std::string svg = board_svg(b, 0.02);
  EXPECT_NE(svg.find("width=\"230.0000mm\" height=\"180.0000mm\""), std::string::npos) << svg.substr(0, 300);
}

TEST(Detect, UnreadableImageIsNamed) {
  try {
    read_image_grey("/nonexistent/view.png");
    FAIL();
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/view.png"), std::string::npos);
  }
  // A photo cut short in copying: its name and why, and no raw libpng line on stderr.
  const fs::path cut = fs::temp_directory_path() / ("kumite-cut-" + std::to_string(::getpid()) + ".png");
  std::vector<unsigned char> png;
  cv::imencode(".png", cv::Mat(64, 64, CV_8UC1, cv::Scalar(90)), png);
  std::ofstream(cut, std::ios::binary).write(reinterpret_cast<const char*>(png.data()),
                                             static_cast<std::streamsize>(png.size() / 2));
  testing::internal::CaptureStderr();
  try {
    read_image_grey(cut);
    ADD_FAILURE() << "a cut PNG was read";
  } catch (const kumite::Error& e) {
    EXPECT_NE(std::string(e.what()).find(cut.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("PNG cut short"), std::string::npos) << e.what();
  }
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(err.find("libpng"), std::string::npos) << err;
  fs::remove(cut);
}

namespace {

struct ListedTag {
  int id = 0;
  std::array<cv::Point2d, 4> corners{};  // apriltag convention (+0.5 px)
};

/// apriltag's test photos and their listed corners (../shared/data/calibration/PROVENANCE.md).
struct AprilTagTestPhoto {
  fs::path jpg;
  cv::Mat grey;  // decoded by the library's own JPEG decoder, as upstream's test does
  std::vector<ListedTag> listed;
};

std::vector<AprilTagTestPhoto> apriltag_test_photos() {
  std::vector<AprilTagTestPhoto> photos;
  const fs::path dir = fs::path(KUMITE_SHARED_DATA_DIR) / "calibration/apriltag-test";
  if (!fs::exists(dir)) return photos;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".txt") continue;
    AprilTagTestPhoto photo;
    std::ifstream in(e.path());
    std::string line;
    while (std::getline(in, line)) {
      ListedTag t;
      auto& c = t.corners;
      if (std::sscanf(line.c_str(), "%d, (%lf %lf), (%lf %lf), (%lf %lf), (%lf %lf)", &t.id, &c[0].x, &c[0].y,
                      &c[1].x, &c[1].y, &c[2].x, &c[2].y, &c[3].x, &c[3].y) == 9) {
        photo.listed.push_back(t);
      }
    }
    photo.jpg = e.path();
    photo.jpg.replace_extension(".jpg");
    pjpeg_t* pj = pjpeg_create_from_file(photo.jpg.c_str(), 0, nullptr);
    if (pj == nullptr) throw std::runtime_error("cannot decode " + photo.jpg.string());
    image_u8_t* u8 = pjpeg_to_u8_baseline(pj);
    photo.grey = cv::Mat(u8->height, u8->width, CV_8U, u8->buf, static_cast<std::size_t>(u8->stride)).clone();
    image_u8_destroy(u8);
    pjpeg_destroy(pj);
    photos.push_back(std::move(photo));
  }
  std::sort(photos.begin(), photos.end(), [](const auto& a, const auto& b) { return a.jpg < b.jpg; });
  return photos;
}

}  // namespace

// apriltag's own test data: the corners upstream's test_detection.c printed at commit 1c21707
// with quad_decimate 1 and refine_edges off, i.e. the library's raw corners, to 4 decimals.
// We detect them as `kumite-calibrate ... --blur 0` does (the tool's defaults, decimate 1 and
// no edge refinement, with the blur off), on the image decoded by the library's own JPEG
// decoder, as upstream did (libjpeg's IDCT differs by a grey level here and there). Checks the
// +0.5 px pixel-centre convention, the corner order and that nothing is lost on the way.
//
// Debian's apriltag 3.3.0 alone is off two of these tags by 0.106 and 0.140 px (duplicate edge
// points, fixed upstream after 3.3.0: tag_quads.hpp); the corners BoardDetector re-fits match
// all 47 to 1e-4 px (4 printed decimals of float values).
TEST(Detect, AprilTagKnownAnswerWithinATenthOfAPixel) {
  const auto photos = apriltag_test_photos();
  if (photos.empty()) GTEST_SKIP() << "no shared data at " << KUMITE_SHARED_DATA_DIR;
  Board any;  // detect_tags ignores the board
  DetectorOptions opt = technician_detector();
  opt.quad_sigma = 0;  // --blur 0
  ASSERT_EQ(opt.quad_decimate, 1.f) << "the tool's default --decimate";
  ASSERT_FALSE(opt.refine_edges) << "the tool's default at --decimate 1";
  BoardDetector det(any, opt);
  int listed = 0, within = 0, to_print = 0;
  double worst_all = 0;
  for (const auto& photo : photos) {
    const auto tags = det.detect_tags(photo.grey);
    EXPECT_EQ(tags.size(), photo.listed.size()) << photo.jpg;
    for (const auto& t : tags) EXPECT_TRUE(t.refitted) << photo.jpg << " tag at " << t.corners[0];
    for (const auto& ex : photo.listed) {
      double best = 1e9;
      for (const auto& t : tags) {
        if (t.id != ex.id) continue;
        double worst = 0;
        for (std::size_t k = 0; k < 4; ++k) {
          // Per coordinate, as upstream's own test compares.
          const cv::Point2d d = t.corners[k] + cv::Point2d(0.5, 0.5) - ex.corners[k];
          worst = std::max({worst, std::abs(d.x), std::abs(d.y)});
        }
        best = std::min(best, worst);
      }
      EXPECT_LT(best, 0.1) << photo.jpg << " tag " << ex.id << " listed at " << ex.corners[0];
      ++listed;
      if (best < 0.1) ++within;
      // Printed to 4 decimals, after the library's float round trip (see the next test).
      if (best < 1e-4) ++to_print;
      worst_all = std::max(worst_all, best);
    }
  }
  EXPECT_EQ(photos.size(), 3u);
  EXPECT_EQ(listed, 47);
  EXPECT_EQ(to_print, 47) << "every listed corner reproduced to 1e-4 px";
  std::printf("apriltag known answer: %d of %d tags within 0.1 px, %d within 1e-4 px, worst %.5f px\n",
              within, listed, to_print, worst_all);
}

// fit_tag_quads() is the library's quad search re-done; with the 3.3.0 duplicates kept it must
// give the library's own corners on every tag of the three photos (independent path: the
// library), to the library's float precision. Without them, a tag's quad moves only where
// duplicates were involved, and by little (elsewhere clusters may now pass or fail the quad
// checks, which only changes the candidates that decode to no tag).
TEST(Detect, TagQuadsReproduceTheLibraryAndDifferOnlyByTheDuplicates) {
  // The library stores quad corners in float and reports them through a homography computed
  // from them, which moves them by up to ~3e-5 px at x ~ 700 (float's step there is 6e-5).
  constexpr double kFloatRoundTrip_px = 1e-4;
  const auto photos = apriltag_test_photos();
  if (photos.empty()) GTEST_SKIP() << "no shared data at " << KUMITE_SHARED_DATA_DIR;
  apriltag_detector_t* td = apriltag_detector_create();
  apriltag_family_t* tf = tag36h11_create();
  apriltag_detector_add_family(td, tf);
  td->quad_decimate = 1;
  td->refine_edges = false;
  int tags = 0, same = 0, moved = 0;
  double largest_move = 0;
  for (const auto& photo : photos) {
    cv::Mat im = photo.grey.clone();
    image_u8_t u8{im.cols, im.rows, static_cast<int32_t>(im.step[0]), im.data};
    zarray_t* dets = apriltag_detector_detect(td, &u8);
    QuadFitParams as_330;
    as_330.keep_diagonal_duplicates = true;
    const auto quads_330 = fit_tag_quads(photo.grey, as_330);
    const auto quads = fit_tag_quads(photo.grey);
    auto nearest = [](const std::vector<TagQuad>& qs, const apriltag_detection_t& d) {
      double best = 1e9;
      for (const auto& q : qs) {
        for (int s = 0; s < 4; ++s) {
          for (int step : {1, 3}) {  // any first corner, either winding
            double worst = 0;
            for (int k = 0; k < 4; ++k) {
              const cv::Point2d& p = q.p[static_cast<std::size_t>((s + step * k) & 3)];
              worst = std::max(worst, std::hypot(p.x - d.p[k][0], p.y - d.p[k][1]));
            }
            best = std::min(best, worst);
          }
        }
      }
      return best;
    };
    for (int i = 0; i < zarray_size(dets); ++i) {
      apriltag_detection_t* d = nullptr;
      zarray_get(dets, i, &d);
      ++tags;
      const double e330 = nearest(quads_330, *d);
      EXPECT_LT(e330, kFloatRoundTrip_px) << photo.jpg << " tag at " << d->p[0][0] << ", " << d->p[0][1];
      const double e = nearest(quads, *d);
      EXPECT_LT(e, 0.5) << photo.jpg << " tag at " << d->p[0][0] << ", " << d->p[0][1];
      if (e < kFloatRoundTrip_px) {
        ++same;
      } else {
        ++moved;
      }
      largest_move = std::max(largest_move, e);
    }
    apriltag_detections_destroy(dets);
  }
  apriltag_detector_destroy(td);
  tag36h11_destroy(tf);
  EXPECT_EQ(tags, 47);
  EXPECT_GE(same, 40);
  EXPECT_GE(moved, 2) << "the two tags the upstream fix moved";
  std::printf("tag quads: %d tags, %d identical to apriltag 3.3.0, %d moved by up to %.4f px without duplicates\n",
              tags, same, moved, largest_move);
}

// With the 3.3.0 duplicates kept, fit_tag_quads() must give every quad the library's own
// quad search gives, float for float, and no other: on the three photos, blurred and not,
// and on SYNTHETIC images of small dark quads (some cut by the image border, some below the
// library's minimum area) with sensor noise.
TEST(Detect, TagQuadsAreTheLibrarysQuadsExactly) {
  apriltag_detector_t* td = apriltag_detector_create();
  apriltag_family_t* tf = tag36h11_create();
  apriltag_detector_add_family(td, tf);
  td->quad_decimate = 1;
  td->refine_edges = false;
  {
    // apriltag_quad_thresh needs the worker pool apriltag_detector_detect creates.
    cv::Mat blank(16, 16, CV_8U, cv::Scalar(0));
    image_u8_t u8{16, 16, 16, blank.data};
    apriltag_detections_destroy(apriltag_detector_detect(td, &u8));
  }
  QuadFitParams as_330;
  as_330.keep_diagonal_duplicates = true;
  using Corners = std::array<float, 8>;
  auto differences = [&](const cv::Mat& grey) {
    cv::Mat copy = grey.clone();
    image_u8_t u8{copy.cols, copy.rows, static_cast<int32_t>(copy.step[0]), copy.data};
    zarray_t* lib = apriltag_quad_thresh(td, &u8);
    std::multiset<Corners> theirs, ours;
    for (int i = 0; i < zarray_size(lib); ++i) {
      quad* q = nullptr;
      zarray_get_volatile(lib, i, &q);
      theirs.insert({q->p[0][0], q->p[0][1], q->p[1][0], q->p[1][1], q->p[2][0], q->p[2][1], q->p[3][0], q->p[3][1]});
    }
    zarray_destroy(lib);
    for (const auto& q : fit_tag_quads(grey, as_330)) {
      Corners c{};
      for (std::size_t k = 0; k < 4; ++k) {
        c[2 * k] = static_cast<float>(q.p[k].x);
        c[2 * k + 1] = static_cast<float>(q.p[k].y);
      }
      ours.insert(c);
    }
    std::vector<Corners> diff;
    std::set_symmetric_difference(theirs.begin(), theirs.end(), ours.begin(), ours.end(), std::back_inserter(diff));
    return std::make_pair(diff.size(), theirs.size());
  };
  std::size_t photo_quads = 0;
  const auto photos = apriltag_test_photos();
  for (const auto& photo : photos) {
    for (double blur : {0.0, 0.8}) {
      cv::Mat g = photo.grey;
      if (blur > 0) cv::GaussianBlur(photo.grey, g, cv::Size(0, 0), blur);
      const auto [diff, n] = differences(g);
      EXPECT_EQ(diff, 0u) << photo.jpg << " blur " << blur << ": " << n << " library quads";
      photo_quads += n;
    }
  }
  cv::RNG rng(1);
  std::size_t synthetic_quads = 0;
  int images_differing = 0;
  for (int t = 0; t < 400; ++t) {
    const int w = rng.uniform(40, 100), h = rng.uniform(40, 100);
    cv::Mat g(h, w, CV_8U, cv::Scalar(rng.uniform(150, 256)));
    for (int k = rng.uniform(1, 6); k > 0; --k) {
      const cv::Point2f c(rng.uniform(0.f, static_cast<float>(w)), rng.uniform(0.f, static_cast<float>(h)));
      const float size = rng.uniform(3.f, 20.f), angle = rng.uniform(0.f, 6.28f);
      std::vector<cv::Point> pts;
      for (int j = 0; j < 4; ++j) {
        const float a = angle + static_cast<float>(j) * 1.5708f + rng.uniform(-0.2f, 0.2f);
        pts.emplace_back(cvRound((c.x + size * std::cos(a)) * 16), cvRound((c.y + size * std::sin(a)) * 16));
      }
      cv::fillConvexPoly(g, pts, cv::Scalar(rng.uniform(0, 100)), cv::LINE_AA, 4);
    }
    cv::Mat noise(h, w, CV_8U);
    rng.fill(noise, cv::RNG::NORMAL, 0, rng.uniform(0, 8));
    cv::add(g, noise, g);
    const auto [diff, n] = differences(g);
    if (diff != 0) ++images_differing;
    synthetic_quads += n;
  }
  EXPECT_EQ(images_differing, 0) << "of 400 synthetic images";
  // (A clone without ../shared has no photos: the synthetic half still runs, and says so.)
  if (!photos.empty()) EXPECT_GT(photo_quads, 200u);
  else std::printf("no shared data at %s: the photos are left out\n", KUMITE_SHARED_DATA_DIR.c_str());
  EXPECT_GT(synthetic_quads, 300u);
  std::printf("library quads reproduced: %zu on the photos, %zu on 400 synthetic images\n", photo_quads,
              synthetic_quads);
  apriltag_detector_destroy(td);
  tag36h11_destroy(tf);
}

TEST(Detect, TagQuadsSurviveNoiseAndTinyImages) {
  cv::Mat noise(240, 320, CV_8U);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  for (const auto& q : fit_tag_quads(noise)) {
    for (const auto& p : q.p) EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y));
  }
  // Too small for the threshold tiles (without the guard: reads outside the tile maps).
  for (const cv::Size size : {cv::Size(300, 3), cv::Size(3, 300), cv::Size(7, 7), cv::Size(1, 1)}) {
    cv::Mat tiny(size, CV_8U);
    rng.fill(tiny, cv::RNG::UNIFORM, 0, 256);
    EXPECT_TRUE(fit_tag_quads(tiny).empty()) << size;
  }
  // A single black square on white: one quad, its corners on the square's outline.
  cv::Mat square(64, 64, CV_8U, cv::Scalar(255));
  cv::rectangle(square, cv::Rect(16, 20, 30, 24), cv::Scalar(0), cv::FILLED);
  const auto quads = fit_tag_quads(square);
  ASSERT_EQ(quads.size(), 1u);
  for (const auto& p : quads[0].p) {
    // Edges half-way between the last black and first white pixel, +0.5 px (apriltag's
    // convention): x at 16 or 46, y at 20 or 44.
    EXPECT_NEAR(std::min(std::abs(p.x - 16), std::abs(p.x - 46)), 0, 0.05) << p;
    EXPECT_NEAR(std::min(std::abs(p.y - 20), std::abs(p.y - 44)), 0, 0.05) << p;
  }
}

TEST(Board, ShippedBoardFilesParse) {
  const fs::path dir = fs::path(KUMITE_SOURCE_DIR) / "config/boards";
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".toml") continue;
    EXPECT_NO_THROW(read_board(e.path())) << e.path();
    ++n;
  }
  EXPECT_GE(n, 3);
}

TEST(Board, BoardCommandWritesPngSvgAndToml) {
  const fs::path dir = fs::temp_directory_path() / ("kumite_board_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  BoardCommand cmd;
  cmd.board = tag_board();
  cmd.dpi = 150;
  cmd.out_prefix = dir / "b";
  run_board(cmd);
  const cv::Mat png = cv::imread((dir / "b.png").string(), cv::IMREAD_GRAYSCALE);
  const double margin = tag_board().default_margin_m();
  EXPECT_EQ(png.cols, static_cast<int>(std::lround((0.19 + 2 * margin) / 0.0254 * 150)));
  const Board back = read_board(dir / "b.toml");
  EXPECT_EQ(back.first_id, 5);
  EXPECT_TRUE(fs::exists(dir / "b.svg"));
  // The printed PNG is detected as the board it describes.
  BoardDetector det(back);
  EXPECT_EQ(det.detect(png).size(), 48u);
  fs::remove_all(dir);
}
