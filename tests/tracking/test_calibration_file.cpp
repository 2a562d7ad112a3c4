#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>

#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace fs = std::filesystem;
using namespace kumite::tracking;

namespace {
fs::path temp_file(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("kumite-calfile-" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d / name;
}

RigCalibration two_cameras() {
  RigCalibration rig;
  for (int i = 0; i < 2; ++i) {
    CameraCalibration c;
    c.name = "cam" + std::to_string(i);
    c.image_width = 1280;
    c.image_height = 1024;
    c.camera_matrix = cv::Matx33d(900 + i, 0, 640.5, 0, 901, 512.25, 0, 0, 1);
    c.distortion = {-0.1, 0.05, 0.001, -0.002, 0.0003};
    cv::Mat R;
    cv::Rodrigues(cv::Vec3d(0.1 * (i + 1), -0.7, 0.05), R);
    c.rotation = cv::Matx33d(R);
    c.translation = {0.1, -1.2, 2.5 + i};
    if (i == 0) {
      c.rms_px = 0.31;
      c.per_view_errors_px = {0.2, -1.0, 0.4};  // -1: a view without the board (as the tools write)
    }
    rig.cameras.push_back(c);
  }
  return rig;
}

void write_text(const fs::path& p, const std::string& s) { std::ofstream(p) << s; }

std::string error_of(const fs::path& p) {
  try {
    read_calibration(p);
  } catch (const kumite::Error& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(CalibrationFile, RoundTrip) {
  const fs::path p = temp_file("rig.yaml");
  const RigCalibration rig = two_cameras();
  write_calibration(p, rig);
  const RigCalibration back = read_calibration(p);
  ASSERT_EQ(back.cameras.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const auto& a = rig.cameras[i];
    const auto& b = back.cameras[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.image_width, b.image_width);
    EXPECT_LT(cv::norm(a.camera_matrix - b.camera_matrix), 1e-12);
    EXPECT_LT(cv::norm(a.rotation - b.rotation), 1e-12);
    EXPECT_LT(cv::norm(a.translation - b.translation), 1e-12);
    EXPECT_LT(cv::norm(a.distortion - b.distortion), 1e-12);
  }
  EXPECT_DOUBLE_EQ(*back.cameras[0].rms_px, 0.31);
  ASSERT_EQ(back.cameras[0].per_view_errors_px.size(), 3u);
  EXPECT_EQ(back.cameras[0].per_view_errors_px[1], -1.0);  // read back (session 18 refused it for a while)
  EXPECT_FALSE(back.cameras[1].rms_px);
  EXPECT_NE(back.find("cam1"), nullptr);
  EXPECT_EQ(back.find("cam9"), nullptr);
}

TEST(CalibrationFile, PositionIsMinusRtT) {
  CameraCalibration c;
  cv::Mat R;
  cv::Rodrigues(cv::Vec3d(0.3, 0.2, -0.1), R);
  c.rotation = cv::Matx33d(R);
  const cv::Vec3d centre(1.5, 2.5, -1.5);
  c.translation = -(c.rotation * centre);
  EXPECT_LT(cv::norm(c.position() - centre), 1e-12);
}

TEST(CalibrationFile, MissingFileIsNamed) {
  EXPECT_NE(error_of("/nonexistent/cal.yaml").find("/nonexistent/cal.yaml: no such file"),
            std::string::npos);
  // A folder was "not valid YAML: buf" (OpenCV's words).
  const fs::path dir = temp_file("x").parent_path();
  EXPECT_EQ(error_of(dir), dir.string() + ": is a folder, not a file: give the calibration .yaml");
}

TEST(CalibrationFile, NonFiniteNumbersAreNamedWithTheirLine) {
  // Every number read must be finite (issue 15): a .nan in a matrix said "non-finite value"
  // without a line, and rms_px / per_view_errors_px took nan and inf as they came.
  const fs::path good = temp_file("finite.yaml");
  write_calibration(good, two_cameras());
  std::ifstream in(good);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  const auto line_of = [&](const std::string& text, std::size_t from = 0) {
    for (std::size_t i = from; i < lines.size(); ++i)
      if (lines[i].find(text) != std::string::npos) return i;
    return lines.size();
  };
  const auto with = [&](std::size_t i, const std::string& from, const std::string& to) {
    std::vector<std::string> v = lines;
    const std::size_t at = v[i].find(from);
    if (at == std::string::npos) return std::string();
    v[i].replace(at, from.size(), to);
    const fs::path p = temp_file("nonfinite.yaml");
    std::string text;
    for (const auto& l : v) text += l + "\n";
    write_text(p, text);
    return error_of(p);
  };
  const std::size_t k = line_of("camera_matrix");
  const std::size_t data = line_of("data:", k);
  ASSERT_LT(data, lines.size());
  EXPECT_EQ(with(data, "900.", ".nan"), temp_file("nonfinite.yaml").string() + ":" + std::to_string(data + 1) +
                                            ": cameras[0] (cam0).camera_matrix: must be a finite number");
  const std::size_t rms = line_of("rms_px");
  ASSERT_LT(rms, lines.size());
  const std::string value = lines[rms].substr(lines[rms].find(':') + 1);
  EXPECT_EQ(with(rms, value, " -.Inf"), temp_file("nonfinite.yaml").string() + ":" + std::to_string(rms + 1) +
                                           ": cameras[0] (cam0).rms_px: must be a finite number");
  const std::size_t errs = line_of("data:", line_of("per_view_errors_px"));
  ASSERT_LT(errs, lines.size());
  const std::size_t open = lines[errs].find("[ ") + 2;
  const std::string first = lines[errs].substr(open, lines[errs].find(',', open) - open);  // the first error
  EXPECT_EQ(with(errs, first, ".inf"), temp_file("nonfinite.yaml").string() + ":" + std::to_string(errs + 1) +
                                           ": cameras[0] (cam0).per_view_errors_px: must be a finite number");
  // -1 is "board not seen in that view"; any other negative error is refused.
  EXPECT_EQ(with(errs, first, "-0.5"), temp_file("nonfinite.yaml").string() +
                                           ": cameras[0] (cam0).per_view_errors_px: must be >= 0 (or -1: board not seen)");
}

TEST(CalibrationFile, BadFieldsAreNamed) {
  const fs::path p = temp_file("bad.yaml");
  write_text(p, "%YAML:1.0\n---\ncameras:\n  - { name: camA, image_width: 640, image_height: 480 }\n");
  EXPECT_NE(error_of(p).find("cameras[0] (camA).camera_matrix: missing"), std::string::npos)
      << error_of(p);

  write_text(p, "%YAML:1.0\n---\nfoo: 1\n");
  EXPECT_NE(error_of(p).find("cameras: missing"), std::string::npos) << error_of(p);

  write_text(p, "this is : : not yaml [\n");
  EXPECT_NE(error_of(p).find(p.string()), std::string::npos);

  // Found by fuzzing: OpenCV 4.6's parser loops forever on this; refused before it.
  write_text(p, "%YAML:1.0\n---L:0\n--\n-");
  EXPECT_NE(error_of(p).find(p.string() + ":2: a document marker (---) stands alone on its line"), std::string::npos)
      << error_of(p);

  // Found by fuzzing (CI, 2026-11-23): an indented marker hangs the same parser.
  write_text(p, "%YAML:1.0\n   ---\n# Kumite rig\n cameras:\n   - name: cam2\n");
  EXPECT_NE(error_of(p).find(p.string() + ":2: a document marker (---) starts its line"), std::string::npos)
      << error_of(p);

  // Found by fuzzing (CI, 2026-11-28): content after a flow sequence on its line hangs the same
  // parser; every file now goes through libyaml first, and what it refuses is said with its line.
  write_text(p, "%YAML:1.0\n---\n[0,]  -\n");
  EXPECT_NE(error_of(p).find(p.string() + ":3: not valid YAML: "), std::string::npos) << error_of(p);
  EXPECT_EQ(error_of(p).find('\n'), std::string::npos) << error_of(p);
  // And the whole input the fuzzer found.
  write_text(p, "%YAML:1.0\n---\n#  d\n   # Kumite rig ca    dt: d\n  [      data: [ -7.0710671881,\n"
                "             -      data: [ -7..34622326111985e-01,\n             -3.89490e+00, 300 ]\n   -\n      001");
  EXPECT_NE(error_of(p).find(p.string() + ":"), std::string::npos) << error_of(p);

  // Found by fuzzing past libyaml (session 23): a lone carriage return is a line break to
  // libyaml and none to OpenCV; the two read different documents and OpenCV hung.
  write_text(p, "%YAML:1.0\n---\n\rK\n[+00,]\n-");
  EXPECT_NE(error_of(p).find(p.string() + ":3: a carriage return inside a line"), std::string::npos) << error_of(p);
  write_text(p, "%YAML:1.0\n---\ncameras:\xe2\x80\xa8 - name: cam0\n");
  EXPECT_NE(error_of(p).find(p.string() + ":3: a Unicode line separator inside a line"), std::string::npos) << error_of(p);

  // Not a rotation.
  RigCalibration rig = two_cameras();
  rig.cameras[1].rotation(0, 0) = 2.0;
  write_calibration(p, rig);
  EXPECT_NE(error_of(p).find("cameras[1] (cam1).rotation: not a rotation"), std::string::npos)
      << error_of(p);

  // Duplicate names.
  rig = two_cameras();
  rig.cameras[1].name = "cam0";
  write_calibration(p, rig);
  EXPECT_NE(error_of(p).find("duplicate camera name"), std::string::npos) << error_of(p);
}
