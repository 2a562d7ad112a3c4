// Writes a SYNTHETIC 4-camera calibration data set (what the tests and the benchmark use) to
// a folder, laid out like a recording, so the tool can be tried end to end:
//   OUT/board.toml, OUT/views/camN/NNNNNN.png (board carried through the volume),
//   OUT/floor/camN/000000.png (board on the floor, origin at (-0.35, 0, 0.2), yaw 30 deg),
//   OUT/truth.yaml (the true cameras in the room frame).
// Usage: kumite_make_synthetic_rig OUT [FRAMES]   (--help for the options)
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>

#include "kumite/calibration/rig.hpp"
#include "kumite/calibration/synthetic.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace fs = std::filesystem;
using namespace kumite::calibration;
namespace syn = kumite::calibration::synthetic;

namespace {

constexpr const char* kName = "kumite_make_synthetic_rig";
bool g_progress_shown = false;  // "\rframe i/n" on stderr: an error starts a line of its own

/// PNG written atomically (no half-written image if the run is interrupted).
void write_png(const fs::path& path, const cv::Mat& image) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) throw kumite::Error("io", "png", "cannot encode " + path.string());
  kumite::write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

/// OUT made with its parents, or one line saying why not (a file in the way, no permission).
void make_folder(const fs::path& dir) {
  std::error_code ec;
  for (fs::path p = dir; !p.empty() && p != p.parent_path(); p = p.parent_path()) {
    if (!fs::exists(p, ec)) continue;
    if (!fs::is_directory(p, ec))
      throw kumite::Error("io", "folder",
                          fmt::format("{}: cannot create the folder: {} is a file, not a folder", dir.string(), p.string()));
    break;
  }
  fs::create_directories(dir, ec);
  if (ec) throw kumite::Error("io", "folder", fmt::format("{}: cannot create the folder ({})", dir.string(), ec.message()));
}

int make_rig(const fs::path& out, int frames) {
  Board b;
  b.rows = 5;
  b.cols = 7;
  b.tag_size_m = 0.09;
  b.gap_m = 0.02;
  make_folder(out);
  kumite::write_file_atomically(out / "board.toml", board_to_toml(b));
  std::vector<syn::Camera> cams;
  kumite::tracking::RigCalibration truth;
  int i = 0;
  for (const auto& xz : {cv::Vec2d(-1.7, -1.7), cv::Vec2d(1.7, -1.7), cv::Vec2d(1.7, 1.7), cv::Vec2d(-1.7, 1.7)}) {
    const cv::Vec<double, 5> dist(-0.12 + 0.01 * i, 0.03, 0.0004 * i, -0.0003, 0.0);
    cams.push_back(syn::look_at({xz[0], 2.5, xz[1]}, {0, 0.9, 0}, {0, 1, 0}, {1280, 720}, 1000 + 20 * i, dist));
    kumite::tracking::CameraCalibration k;
    k.name = fmt::format("cam{}", i);
    k.image_width = 1280;
    k.image_height = 720;
    k.camera_matrix = cams.back().K;
    k.distortion = dist;
    k.rotation = cams.back().R;
    k.translation = cams.back().t;
    truth.cameras.push_back(k);
    fs::create_directories(out / "views" / k.name);
    fs::create_directories(out / "floor" / k.name);
    ++i;
  }
  kumite::tracking::write_calibration(out / "truth.yaml", truth);
  const BoardPattern pattern(b);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-0.9, 0.9), uy(0.6, 1.6), uyaw(0, 360), utilt(-35, 35), uaxis(0, 180);
  syn::RenderOptions ro;
  ro.supersample = 2;
  const cv::Rect2d e = b.pattern_extent();
  for (int f = 0; f < frames; ++f) {
    const RigidPose up = floor_board_pose({0, 0, 0}, uyaw(rng));
    const double a = uaxis(rng) * CV_PI / 180;
    syn::Pose pose;
    pose.R = syn::rotation({std::cos(a), 0, std::sin(a)}, utilt(rng)) * up.R;
    pose.t = cv::Vec3d(ux(rng), uy(rng), ux(rng)) - pose.R * cv::Vec3d(e.x + e.width / 2, e.y + e.height / 2, 0);
    for (std::size_t c = 0; c < cams.size(); ++c) {
      ro.seed = static_cast<std::uint64_t>(f * 10 + static_cast<int>(c) + 1);
      write_png(out / "views" / truth.cameras[c].name / fmt::format("{:06d}.png", f),
                syn::render_view(pattern, b, cams[c], pose, ro));
    }
    std::fprintf(stderr, "\rframe %d/%d", f + 1, frames);
    g_progress_shown = true;
  }
  const RigidPose floor = floor_board_pose({-0.35, 0.0, 0.2}, 30.0);
  for (std::size_t c = 0; c < cams.size(); ++c) {
    write_png(out / "floor" / truth.cameras[c].name / "000000.png",
              syn::render_view(pattern, b, cams[c], {floor.R, floor.t}, ro));
  }
  std::fprintf(stderr, "\nwrote %s (SYNTHETIC: truth in truth.yaml)\n", out.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Writes a SYNTHETIC 4-camera calibration data set to OUT, laid out like a recording: "
               "board.toml, views/camN/NNNNNN.png (the board carried through the volume), "
               "floor/camN/000000.png (the board on the floor), truth.yaml (the true cameras)",
               kName};
  std::string out;
  int frames = 40;
  app.add_option("out", out, "folder to write (made if missing)")->required();
  app.add_option("frames", frames, "board poses to render (views per camera), 1..100000")->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::cerr << kName << ": " << e.what() << " (--help for usage)\n";
    return 1;
  }
  if (frames < 1 || frames > 100000) {
    std::cerr << kName << ": frames: must be 1..100000, got " << frames << " (--help for usage)\n";
    return 1;
  }
  try {
    return make_rig(out, frames);
  } catch (const std::exception& e) {
    std::cerr << (g_progress_shown ? "\n" : "") << kName << ": " << e.what() << "\n";
    return 1;
  }
}
