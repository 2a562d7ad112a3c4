// Fuzzes the calibration reader (OpenCV FileStorage YAML): every input must be read and
// validated or throw kumite::Error; never crash. The reader takes a path, so each input goes
// through a temporary file.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("kumite-fuzz-cal-" + std::to_string(::getpid()) + ".yaml");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const auto rig = kumite::tracking::read_calibration(path);
    for (const auto& c : rig.cameras) {
      if (c.image_width <= 0 || c.image_height <= 0) std::abort();
      for (int i = 0; i < 9; ++i) if (!std::isfinite(c.rotation.val[i])) std::abort();
    }
  } catch (const kumite::Error&) {
  } catch (const cv::Exception&) {
    std::abort();  // the reader must turn OpenCV's exceptions into kumite::Error
  }
  return 0;
}
