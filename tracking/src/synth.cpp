#include "kumite/tracking/synth.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/time.hpp"
#include "kumite/tracking/geometry.hpp"
#include "kumite/tracking/tracker.hpp"

namespace kumite::tracking {
namespace fs = std::filesystem;

namespace {

/// 0 outside [a, b], a smooth sin^2 bump of height 1 inside.
double bump(double t, double a, double b) {
  if (t <= a || t >= b) return 0;
  const double s = std::sin(M_PI * (t - a) / (b - a));
  return s * s;
}

Eigen::Quaterniond yaw_pitch_roll(double yaw, double pitch, double roll) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ());
}

}  // namespace

TrajectoryPoint scripted_visitor(Timestamp t) {
  TrajectoryPoint p;
  p.t = t;
  const double dodge = 0.3 * (bump(std::fmod(t, 7.0), 4.5, 5.3) - bump(std::fmod(t + 3.5, 7.0), 4.5, 5.3));
  const double crouch = 0.45 * bump(std::fmod(t, 11.0), 6.0, 8.5);
  p.position = {0.6 * std::sin(0.5 * t) + dodge, 1.65 - crouch + 0.02 * std::sin(2 * M_PI * 1.8 * t),
                0.5 * std::sin(0.37 * t + 0.5)};
  p.orientation = yaw_pitch_roll(0.5 * std::sin(0.4 * t), 0.15 * std::sin(0.9 * t), 0.08 * std::sin(0.6 * t));
  return p;
}

TrajectoryPoint static_visitor(Timestamp t) {
  TrajectoryPoint p;
  p.t = t;
  p.position = {0.1, 1.65, -0.2};
  p.orientation = yaw_pitch_roll(0.3, -0.1, 0.05);
  return p;
}

std::vector<TrajectoryPoint> read_trajectory_csv(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("synth", "missing", fmt::format("{}: cannot open trajectory", path.string()));
  std::string line;
  std::vector<TrajectoryPoint> out;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (n == 1) {
      if (line.rfind("timestamp_s,x,y,z,qw,qx,qy,qz", 0) != 0) {
        throw file_error("synth", "header", path.string(), 1, "", "expected the header \"timestamp_s,x,y,z,qw,qx,qy,qz\"");
      }
      continue;
    }
    std::stringstream ss(line);
    double v[8];
    char comma;
    bool ok = true;
    for (int k = 0; k < 8 && ok; ++k) {
      ok = static_cast<bool>(ss >> v[k]) && std::isfinite(v[k]);
      if (ok && k < 7) ok = static_cast<bool>(ss >> comma) && comma == ',';
    }
    if (!ok) throw file_error("synth", "row", path.string(), n, "", "expected 8 numbers");
    TrajectoryPoint p;
    p.t = v[0];
    p.position = {v[1], v[2], v[3]};
    p.orientation = Eigen::Quaterniond(v[4], v[5], v[6], v[7]);
    if (p.orientation.norm() < 0.5) throw file_error("synth", "row", path.string(), n, "qw", "not a unit quaternion");
    p.orientation.normalize();
    if (!out.empty() && p.t <= out.back().t) throw file_error("synth", "row", path.string(), n, "timestamp_s", "must increase");
    out.push_back(p);
  }
  if (out.empty()) throw file_error("synth", "empty", path.string(), 0, "", "no trajectory rows");
  return out;
}

TrajectoryPoint sample(const std::vector<TrajectoryPoint>& tr, Timestamp t) {
  if (tr.empty()) return {};
  if (t <= tr.front().t) return tr.front();
  if (t >= tr.back().t) return tr.back();
  auto it = std::lower_bound(tr.begin(), tr.end(), t, [](const TrajectoryPoint& p, double x) { return p.t < x; });
  const TrajectoryPoint& b = *it;
  const TrajectoryPoint& a = *(it - 1);
  const double s = (t - a.t) / (b.t - a.t);
  TrajectoryPoint p;
  p.t = t;
  p.position = a.position + s * (b.position - a.position);
  p.orientation = a.orientation.slerp(s, b.orientation);
  return p;
}

// ---------------------------------------------------------------------------------------

SyntheticRenderer::SyntheticRenderer(const RigCalibration& rig, const BodyConfig& body, SynthOptions options)
    : SyntheticRenderer(rig, std::vector<BodyConfig>{body}, std::move(options)) {}

SyntheticRenderer::SyntheticRenderer(const RigCalibration& rig, std::vector<BodyConfig> bodies, SynthOptions options)
    : rig_(rig), bodies_(std::move(bodies)), options_(std::move(options)), rng_(options_.seed) {
  if (bodies_.empty()) throw Error("synth", "range", "synthetic renderer: no body to draw");
  for (const BodyConfig& b : bodies_) {
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& m : b.markers) c += m;
    centroids_.push_back(c / static_cast<double>(std::max<std::size_t>(1, b.markers.size())));
  }
  std::uniform_real_distribution<double> u(0, 1);
  for (const auto& cam : rig_.cameras) {
    std::vector<cv::Mat> bgs;
    for (int k = 0; k < 3; ++k) {
      cv::Mat bg(cam.image_height, cam.image_width, CV_8UC1);
      cv::RNG rng(options_.seed * 7919ULL + bgs.size() + 131ULL * backgrounds_.size());
      rng.fill(bg, cv::RNG::NORMAL, options_.background, options_.image_noise);
      bgs.push_back(bg);
    }
    backgrounds_.push_back(std::move(bgs));
    std::vector<cv::Point2d> lamps;
    for (int k = 0; k < options_.static_lamps; ++k) {
      lamps.emplace_back(20 + u(rng_) * (cam.image_width - 40), 20 + u(rng_) * (cam.image_height - 40));
    }
    lamps_.push_back(std::move(lamps));
  }
}

std::vector<Eigen::Vector3d> SyntheticRenderer::marker_positions(const TrajectoryPoint& pose) const {
  return marker_positions(0, pose);
}

std::vector<Eigen::Vector3d> SyntheticRenderer::marker_positions(std::size_t body, const TrajectoryPoint& pose) const {
  std::vector<Eigen::Vector3d> out;
  for (const auto& m : bodies_.at(body).markers) out.push_back(pose.position + pose.orientation * (m - centroids_[body]));
  return out;
}

void SyntheticRenderer::draw_spot(cv::Mat& img, double x, double y, double sigma, double peak) {
  std::normal_distribution<double> noise(0, std::max(options_.image_noise, 1e-9));
  const int r = static_cast<int>(std::ceil(3.5 * sigma)) + 1;
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  const double k = 1.0 / (2 * sigma * sigma);
  for (int row = std::max(0, cy - r); row <= std::min(img.rows - 1, cy + r); ++row) {
    auto* p = img.ptr<std::uint8_t>(row);
    for (int col = std::max(0, cx - r); col <= std::min(img.cols - 1, cx + r); ++col) {
      const double d2 = (col - x) * (col - x) + (row - y) * (row - y);
      // Fresh sensor noise where it matters (the spots); the background keeps its own.
      const double v = p[col] + peak * std::exp(-d2 * k) + (options_.image_noise > 0 ? noise(rng_) : 0.0);
      p[col] = cv::saturate_cast<std::uint8_t>(v);
    }
  }
}

FrameSet SyntheticRenderer::render(std::uint64_t frame, const TrajectoryPoint& pose) {
  const std::optional<TrajectoryPoint> one[1] = {pose};
  return render(frame, pose.t, one);
}

FrameSet SyntheticRenderer::render(std::uint64_t frame, Timestamp t, std::span<const std::optional<TrajectoryPoint>> poses) {
  FrameSet set;
  set.frame = frame;
  set.timestamp = t;
  set.images.resize(rig_.cameras.size());
  set.camera_times.assign(rig_.cameras.size(), t);
  // Every drawn body's markers; hidden_markers are body 0's.
  std::vector<Eigen::Vector3d> markers;
  std::vector<int> hideable;  // body 0's model index, -1 for other bodies' markers
  for (std::size_t b = 0; b < bodies_.size() && b < poses.size(); ++b) {
    if (!poses[b]) continue;
    const auto m = marker_positions(b, *poses[b]);
    for (std::size_t k = 0; k < m.size(); ++k) {
      markers.push_back(m[k]);
      hideable.push_back(b == 0 ? static_cast<int>(k) : -1);
    }
  }
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> jitter(0, std::max(options_.centroid_sigma_px, 1e-12));
  for (std::size_t c = 0; c < rig_.cameras.size(); ++c) {
    const bool dead = static_cast<int>(c) == options_.dead_camera && t >= options_.dead_after_s;
    const bool dropped = options_.drop_probability > 0 && u(rng_) < options_.drop_probability;
    if (dead || dropped) continue;
    const CameraModel cam(rig_.cameras[c]);
    cv::Mat img = backgrounds_[c][frame % backgrounds_[c].size()].clone();
    for (std::size_t m = 0; m < markers.size(); ++m) {
      const bool hiding = t >= options_.hide_from_s && t < options_.hide_until_s;
      if (hiding && hideable[m] >= 0 &&
          std::find(options_.hidden_markers.begin(), options_.hidden_markers.end(), hideable[m]) !=
              options_.hidden_markers.end()) {
        continue;
      }
      Eigen::Vector2d px;
      if (!cam.project(markers[m], px)) continue;
      const double depth = cam.to_camera(markers[m]).z();
      const double radius = cam.focal_px() * 0.5 * options_.marker_diameter_m / depth;
      const double sigma = std::sqrt(0.25 * radius * radius + options_.blur_px * options_.blur_px);
      draw_spot(img, px.x() + jitter(rng_), px.y() + jitter(rng_), sigma, options_.peak);
    }
    for (int k = 0; k < options_.spurious_blobs; ++k) {
      draw_spot(img, 10 + u(rng_) * (img.cols - 20), 10 + u(rng_) * (img.rows - 20), 1.0 + u(rng_), 120 + 100 * u(rng_));
    }
    for (const auto& l : lamps_[c]) draw_spot(img, l.x, l.y, 2.5, 230);
    set.images[c] = std::move(img);
  }
  return set;
}

// ---------------------------------------------------------------------------------------

void write_synthetic_recording(const fs::path& dir, const RigCalibration& rig, const BodyConfig& body,
                               const std::vector<TrajectoryPoint>& trajectory, const SynthOptions& options,
                               const std::string& description) {
  std::vector<Timestamp> times;
  std::vector<std::vector<std::optional<TrajectoryPoint>>> poses;
  for (const TrajectoryPoint& p : trajectory) {
    times.push_back(p.t);
    poses.push_back({p});
  }
  write_synthetic_recording(dir, rig, std::vector<BodyConfig>{body}, times, poses, options, description);
}

void write_synthetic_recording(const fs::path& dir, const RigCalibration& rig, const std::vector<BodyConfig>& bodies,
                               const std::vector<Timestamp>& times,
                               const std::vector<std::vector<std::optional<TrajectoryPoint>>>& poses,
                               const SynthOptions& options, const std::string& description) {
  if (times.size() != poses.size())
    throw Error("synth", "range", fmt::format("synthetic recording: {} times for {} frame sets", times.size(), poses.size()));
  if (fs::exists(dir) && !fs::is_empty(dir)) {
    throw Error("synth", "exists", fmt::format("{}: exists and is not empty (will not overwrite a recording)", dir.string()));
  }
  fs::create_directories(dir);
  for (const auto& cam : rig.cameras) fs::create_directories(dir / cam.name);
  SyntheticRenderer renderer(rig, bodies, options);
  std::vector<FrameRow> frames;
  std::vector<TruthRow> truth;
  std::string all_truth = "frame,timestamp_s,body,x,y,z,qw,qx,qy,qz\n";
  const std::vector<int> png{cv::IMWRITE_PNG_COMPRESSION, 1};
  for (std::size_t i = 0; i < times.size(); ++i) {
    const FrameSet set = renderer.render(i, times[i], poses[i]);
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      if (set.images[c].empty()) continue;
      const fs::path file = dir / rig.cameras[c].name / frame_file_name(i);
      if (!cv::imwrite(file.string(), set.images[c], png)) {
        throw Error("synth", "write", fmt::format("{}: cannot write", file.string()));
      }
    }
    frames.push_back({i, times[i]});
    for (std::size_t b = 0; b < bodies.size() && b < poses[i].size(); ++b) {
      const auto& p = poses[i][b];
      if (!p) continue;
      if (b == 0)
        truth.push_back({i, times[i], p->position.x(), p->position.y(), p->position.z(), p->orientation.w(),
                         p->orientation.x(), p->orientation.y(), p->orientation.z()});
      all_truth += fmt::format("{},{:.6f},{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n", i, times[i], bodies[b].name,
                               p->position.x(), p->position.y(), p->position.z(), p->orientation.w(), p->orientation.x(),
                               p->orientation.y(), p->orientation.z());
    }
  }
  write_frames_csv(dir / "frames.csv", frames);
  write_truth_csv(dir / "truth.csv", truth);
  if (bodies.size() > 1) write_file_atomically(dir / "truth-bodies.csv", all_truth);
  std::string hidden;
  for (int h : options.hidden_markers) hidden += fmt::format("{}{}", hidden.empty() ? "" : ",", h);
  if (!hidden.empty() && (options.hide_from_s > 0 || options.hide_until_s < 1e299)) {
    hidden += fmt::format(" from {} s until {} s", options.hide_from_s, options.hide_until_s);
  }
  const std::string dead = options.dead_camera < 0 ? std::string("none")
                                                   : fmt::format("{} from {} s on", options.dead_camera, options.dead_after_s);
  std::string names;
  for (const auto& b : bodies) names += fmt::format("{}{} ({} markers)", names.empty() ? "" : ", ", b.name, b.markers.size());
  write_file_atomically(dir / "README.txt",
                        fmt::format("SYNTHETIC recording written by kumite-track synth (not camera data).\n"
                                    "{}\nbodies: {}; {} frame sets at {} Hz, {} cameras\n"
                                    "centroid noise sigma {} px per axis, image noise {} grey levels, hidden markers: [{}], "
                                    "spurious blobs/camera: {}, static lamps/camera: {}, dead camera: {}, "
                                    "drop probability: {}, seed {}\n"
                                    "truth.csv is the trajectory body {} was drawn from (body centroid, body->room){}.\n",
                                    description, names, times.size(), options.fps, rig.cameras.size(),
                                    options.centroid_sigma_px, options.image_noise, hidden, options.spurious_blobs,
                                    options.static_lamps, dead, options.drop_probability, options.seed, bodies.front().name,
                                    bodies.size() > 1 ? "; truth-bodies.csv every body's, by name" : ""));
}

RigCalibration corner_rig(double side_m, double height_m, int width, int height, double focal_px) {
  RigCalibration rig;
  const double h = 0.5 * side_m;
  const Eigen::Vector3d target(0, 1.2, 0);
  const Eigen::Vector3d corners[4] = {{-h, height_m, -h}, {h, height_m, -h}, {h, height_m, h}, {-h, height_m, h}};
  for (int i = 0; i < 4; ++i) {
    CameraCalibration cam;
    cam.name = fmt::format("cam{}", i);
    cam.image_width = width;
    cam.image_height = height;
    cam.camera_matrix = cv::Matx33d(focal_px, 0, 0.5 * (width - 1) + 2.5 * (i - 1.5), 0, focal_px * 1.001,
                                    0.5 * (height - 1) - 1.5 * (i - 1.5), 0, 0, 1);
    cam.distortion = {-0.08, 0.02, 0.0005, -0.0003, 0.0};
    // OpenCV camera: +Z forward, +X right, +Y down in the image.
    const Eigen::Vector3d z = (target - corners[i]).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY()).normalized();  // right, level
    const Eigen::Vector3d y = z.cross(x);                                        // down
    Eigen::Matrix3d R;
    R.row(0) = x;
    R.row(1) = y;
    R.row(2) = z;
    const Eigen::Vector3d t = -R * corners[i];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) cam.rotation(r, c) = R(r, c);
      cam.translation[r] = t[r];
    }
    rig.cameras.push_back(cam);
  }
  return rig;
}

namespace {

class SyntheticLiveSource final : public FrameSource {
 public:
  SyntheticLiveSource(const RigCalibration& rig, std::vector<BodyConfig> bodies, BodyPoses poses, double rate_hz,
                      SynthOptions options)
      : renderer_(rig, std::move(bodies), std::move(options)), poses_(std::move(poses)), period_s_(1.0 / rate_hz) {}
  bool next(FrameSet& out, double) override {
    if (n_ == 0) start_ = now();
    // As cameras do for a consumer that is behind: the sets it was too slow for are gone, and
    // the next is the newest one due (a tracker slower than the rate on a loaded machine sees
    // fewer, fresh sets rather than ever older ones).
    const Timestamp late = now() - (start_ + static_cast<double>(n_) * period_s_);
    if (late > period_s_) n_ += static_cast<std::uint64_t>(late / period_s_);
    const Timestamp due = start_ + static_cast<double>(n_) * period_s_;
    sleep_until(due);
    poses_(due - start_, now_poses_);
    out = renderer_.render(n_, due, now_poses_);
    out.timestamp = due;
    out.camera_times.assign(out.images.size(), due);
    ++n_;
    return true;
  }
  bool end_of_stream() const override { return false; }

 private:
  SyntheticRenderer renderer_;
  BodyPoses poses_;
  std::vector<std::optional<TrajectoryPoint>> now_poses_;
  double period_s_;
  std::uint64_t n_ = 0;
  Timestamp start_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> synthetic_live_source(const RigCalibration& rig, const BodyConfig& body,
                                                   std::function<TrajectoryPoint(Timestamp)> trajectory,
                                                   double rate_hz, SynthOptions options) {
  if (!(std::isfinite(rate_hz) && rate_hz > 0 && rate_hz <= 1000))
    throw Error("synth", "range", fmt::format("synthetic live source: rate {} Hz: must be in (0, 1000]", rate_hz));
  return synthetic_live_source(
      rig, std::vector<BodyConfig>{body},
      [trajectory = std::move(trajectory)](Timestamp t, std::vector<std::optional<TrajectoryPoint>>& out) {
        out.assign(1, trajectory(t));
      },
      rate_hz, std::move(options));
}

std::unique_ptr<FrameSource> synthetic_live_source(const RigCalibration& rig, std::vector<BodyConfig> bodies,
                                                   BodyPoses poses, double rate_hz, SynthOptions options) {
  if (!(std::isfinite(rate_hz) && rate_hz > 0 && rate_hz <= 1000))
    throw Error("synth", "range", fmt::format("synthetic live source: rate {} Hz: must be in (0, 1000]", rate_hz));
  return std::make_unique<SyntheticLiveSource>(rig, std::move(bodies), std::move(poses), rate_hz, std::move(options));
}

}  // namespace kumite::tracking
