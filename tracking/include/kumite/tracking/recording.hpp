#pragma once
// Recorded camera frames, the format other tools and the tests write too:
//
//   recording/
//     frames.csv     header "frame,timestamp_s": one row per synchronized frame set
//     cam0/000000.png ...  8-bit greyscale PNG; file name = frame number, 6 digits
//     cam1/ ...      one folder per camera, named as in the calibration file
//     truth.csv      optional ground truth: frame,timestamp_s,x,y,z,qw,qx,qy,qz
//                    (head centroid in m, quaternion body -> room)
//     README.txt     optional free text (synthetic recordings say so there)
//
// A missing PNG means that camera delivered no image for that frame set. Rows whose timestamp
// goes backwards are skipped with a warning; so are unreadable/corrupt PNGs and images of the
// wrong size (that camera gives no image for that frame set).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "kumite/common/time.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::tracking {

/// One frame set: an image (or none) per camera, in calibration order.
struct FrameSet {
  std::uint64_t frame = 0;              ///< frame-set number
  Timestamp timestamp = 0;              ///< s
  std::vector<cv::Mat> images;          ///< per camera; empty Mat = no image this time
  std::vector<Timestamp> camera_times;  ///< s, per camera (capture time; = timestamp when recorded)
};

struct FrameRow {
  std::uint64_t frame = 0;
  Timestamp timestamp = 0;  ///< s
};

struct TruthRow {
  std::uint64_t frame = 0;
  Timestamp timestamp = 0;       ///< s
  double x = 0, y = 0, z = 0;    ///< m
  double qw = 1, qx = 0, qy = 0, qz = 0;
};

/// Parse results keep going past bad rows: `skipped` says which and why (one line each,
/// "frames.csv:12: timestamp_s: goes backwards (...)").
struct FramesIndex {
  std::vector<FrameRow> rows;
  std::vector<std::string> skipped;
};
struct TruthTable {
  std::vector<TruthRow> rows;
  std::vector<std::string> skipped;
  /// Row for `frame`, or nullptr.
  const TruthRow* find(std::uint64_t frame) const;
};

/// Parses frames.csv text. Throws kumite::Error("recording", ...) when the header is wrong;
/// bad rows, duplicate frames and timestamps going backwards are skipped and listed.
FramesIndex parse_frames_csv(std::string_view text, std::string_view source = "frames.csv");
/// Parses truth.csv text (same policy).
TruthTable parse_truth_csv(std::string_view text, std::string_view source = "truth.csv");

/// A recording on disk, bound to a calibration (its camera order).
class Recording {
 public:
  /// Opens `dir`: reads frames.csv (and truth.csv when present) and finds the camera folders.
  /// Throws kumite::Error when the folder or frames.csv is missing, or when no calibrated
  /// camera has a folder; folders of unknown cameras and calibrated cameras without a folder
  /// are reported in warnings() and skipped.
  Recording(const std::filesystem::path& dir, const RigCalibration& rig);

  const std::filesystem::path& dir() const { return dir_; }
  const FramesIndex& index() const { return index_; }
  const std::optional<TruthTable>& truth() const { return truth_; }
  std::size_t size() const { return index_.rows.size(); }
  /// Loads frame set `i` (0-based row). Problems with single images go to `skipped`, one
  /// line each; `skipped_cameras`, if given, gets the camera index of each line.
  FrameSet load(std::size_t i, std::vector<std::string>* skipped = nullptr,
                std::vector<std::size_t>* skipped_cameras = nullptr) const;
  const std::vector<std::string>& warnings() const { return warnings_; }
  /// True when README.txt says the recording is synthetic.
  bool synthetic() const { return synthetic_; }

 private:
  std::filesystem::path dir_;
  std::vector<std::string> names_;
  std::vector<cv::Size> sizes_;
  std::vector<bool> has_folder_;
  FramesIndex index_;
  std::optional<TruthTable> truth_;
  std::vector<std::string> warnings_;
  bool synthetic_ = false;
};

/// Writes frames.csv / truth.csv (atomically).
void write_frames_csv(const std::filesystem::path& path, const std::vector<FrameRow>& rows);
void write_truth_csv(const std::filesystem::path& path, const std::vector<TruthRow>& rows);

/// "000042.png"
std::string frame_file_name(std::uint64_t frame);

/// The image in `file` as 8-bit grey, or an empty Mat and `why` (a few words for a message:
/// "cannot read the file", "cannot decode the image", "PNG cut short ..."). A PNG cut short is
/// found before decoding, so libpng prints nothing of its own. Never throws.
cv::Mat read_grey_image(const std::filesystem::path& file, std::string& why);

}  // namespace kumite::tracking
