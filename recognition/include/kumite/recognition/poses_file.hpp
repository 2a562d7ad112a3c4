#pragma once
// poses.csv (issue 14): one row per tracked body per frame set, as kumite-track --out writes
// it; read by the installation's `[tracking] source = "poses"`, kumite-recognise run and the
// tests. Depends on common only.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/recognition/recognition.hpp"

namespace kumite::recognition {

/// The columns of poses.csv (kumite-track --out, issue 14): one row per body per frame set.
inline constexpr const char* kPosesHeader =
    "frame,timestamp_s,body,status,x,y,z,qw,qx,qy,qz,markers,cameras,latency_ms";
struct PosesFile {
  std::vector<PoseSample> samples;  ///< known roles only, file order
  int ignored_rows = 0;             ///< rows of bodies that are no role (ignored)
};
/// Parses poses.csv: the header line first ('#' lines and blank lines skipped), then rows.
/// body = its name (head, left_hand, ...; other names are ignored); status tracked | coasting
/// | lost (lost = no pose); every number checked finite and in range, timestamps never going
/// back. Throws kumite::Error "file:line: column: message".
PosesFile parse_poses_csv(std::string_view text, std::string_view source);
PosesFile read_poses_csv(const std::filesystem::path& path);
/// The samples as poses.csv (frame = index of the sample's timestamp among distinct ones).
std::string format_poses_csv(const std::vector<PoseSample>& samples);

}  // namespace kumite::recognition
