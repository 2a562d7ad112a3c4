#pragma once
// The kumite-calibrate sub-commands as functions (the tool only parses arguments), so tests
// run them exactly as a technician does. Each throws kumite::Error with a one-line message;
// outputs are written atomically and an existing calibration is kept as a .bak first.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/calibration/board.hpp"
#include "kumite/calibration/detect.hpp"

namespace kumite::calibration {

namespace fs = std::filesystem;

/// Board detections of a list of images of one camera (progress on the console). Throws when
/// an image is unreadable or its size differs from the first one (naming both).
struct CameraViews {
  std::vector<fs::path> images;
  std::vector<BoardDetection> detections;
  cv::Size image_size;
};
CameraViews detect_views(const Board& board, const std::vector<fs::path>& images,
                         const std::string& camera, const DetectorOptions& detector = {});

/// Writes a PNG atomically (temporary file, then rename).
void write_png_atomically(const fs::path& path, const cv::Mat& image);

/// A recording-style folder: DIR/<camera>/<frame>.png. Cameras sorted by name, frames by the
/// union of the file names (a camera may lack some frames).
struct RigImages {
  std::vector<std::string> cameras;
  std::vector<std::string> frames;                 ///< file stems
  std::vector<std::vector<fs::path>> paths;        ///< [camera][frame], empty when missing
};
RigImages scan_rig_images(const fs::path& dir);
/// Detections of every camera's images, on the rig's common frame list.
std::vector<CameraViews> detect_rig(const Board& board, const RigImages& rig, const DetectorOptions& detector = {});

struct BoardCommand {
  Board board;
  fs::path out_prefix = "board";  ///< writes <prefix>.png, <prefix>.svg, <prefix>.toml
  double dpi = 300;
  std::optional<double> margin_m;  ///< default: board.default_margin_m()
};
void run_board(const BoardCommand& cmd);

struct IntrinsicsCommand {
  fs::path board_file;
  std::vector<fs::path> images;
  fs::path out;                    ///< calibration file (other cameras in it are kept)
  std::string name = "cam0";
  bool fix_aspect_ratio = false;
  double outlier_factor = 3.0;
  DetectorOptions detector = technician_detector();  ///< --decimate, --blur, --refine-edges
};
void run_intrinsics(const IntrinsicsCommand& cmd);

struct ExtrinsicsCommand {
  fs::path board_file;
  fs::path images_dir;
  fs::path out;
  std::optional<fs::path> intrinsics;  ///< calibration file with every camera's intrinsics
  bool refine_intrinsics = false;  ///< refine --intrinsics in the adjustment (always when calibrated here)
  double huber_px = 1.0;
  DetectorOptions detector = technician_detector();  ///< --decimate, --blur, --refine-edges
};
void run_extrinsics(const ExtrinsicsCommand& cmd);

/// Three (or more) marked floor points for `align --points`: TOML
///   [[points]]
///   room = [x, y, z]                # m, room frame (y = 0 on the floor)
///   pixels = { cam0 = [u, v], cam1 = [u, v] }   # px, where each camera sees the mark
struct FloorPoint {
  cv::Vec3d room{0, 0, 0};
  std::vector<std::pair<std::string, cv::Point2d>> pixels;
  int line = 0;  ///< in the file, for messages
};
std::vector<FloorPoint> read_floor_points(const fs::path& path);

struct AlignCommand {
  fs::path calibration;            ///< read, aligned, written back (previous version kept)
  std::optional<fs::path> out;     ///< default: overwrite `calibration`
  fs::path board_file;
  fs::path images_dir;             ///< DIR/<camera>/<image>: one image per camera of the board on the floor
  cv::Vec3d board_origin_room{0, 0, 0};  ///< m, room position of the board's origin
  double board_yaw_deg = 0;        ///< rotation of the board about room +Y (0: board +X = room +X)
  std::optional<fs::path> points_file;   ///< alternative: three marked floor points (TOML)
  DetectorOptions detector = technician_detector();  ///< --decimate, --blur, --refine-edges
};
void run_align(const AlignCommand& cmd);

struct ReportCommand {
  fs::path calibration;
  fs::path board_file;
  fs::path images_dir;             ///< DIR/<camera>/... (or a single camera's folder with --camera)
  fs::path out_dir = "report";
  double area_width_m = 3.0;       ///< tracked area (x), centred on the room origin
  double area_depth_m = 3.0;       ///< tracked area (z)
  DetectorOptions detector = technician_detector();  ///< --decimate, --blur, --refine-edges
};
void run_report(const ReportCommand& cmd);

struct WandCommand {
  fs::path calibration;
  fs::path recording_dir;          ///< a recording: frames.csv, <camera>/<frame>.png
  double wand_length_m = 0.5;
  int blob_threshold = 60;         ///< grey level (the tracker's blob detector)
  std::optional<fs::path> out_json;
  std::optional<fs::path> refine_out;  ///< refine camera poses with the wand and write here
};
void run_wand(const WandCommand& cmd);

struct WandResult;
/// The wand figures as JSON text (report.cpp holds the JSON library).
std::string wand_json(const WandCommand& cmd, const WandResult& result);

}  // namespace kumite::calibration
