#pragma once
// kumite export: a run judged and reused from its log alone. Reads a frames.jsonl and writes
// the fighter's performance over [from_s, to_s] as BVH on the character's own skeleton (the
// logged local rotations and root joint, written as they are: no retargeting, no fitting),
// and the visitor's head poses as CSV.
//
// One BVH frame per logged frame; the BVH's frame time is the mean interval of those frames
// (a run in simulated time logs exact steps; a real-time run's late frames are not
// resampled). The interval must hold one character: a switch inside it is refused, naming
// the frame. Bad input (a line that is not JSON, a missing or non-finite number, a joint the
// character's skeleton lacks) throws kumite::Error "file:line: key: message"; a last line cut
// short (a run killed mid-write) is left out with a warning.
#include <filesystem>
#include <optional>
#include <string>

#include "kumite/app/config.hpp"

namespace kumite::app {

struct ExportOptions {
  std::filesystem::path log;                    ///< frames.jsonl
  double from_s = 0;                            ///< s, time_s of the first frame taken (inclusive)
  double to_s = 1e300;                          ///< s, time_s of the last frame taken (inclusive)
  std::optional<std::filesystem::path> bvh;     ///< the fighter's performance (needs the config)
  std::optional<std::filesystem::path> head_csv;///< frame,time_s,x,y,z,qw,qx,qy,qz,live
};

struct ExportReport {
  int frames = 0;              ///< logged frames in the interval
  int first_frame = -1, last_frame = -1;
  double first_time_s = 0, last_time_s = 0;
  int character = -1;          ///< 0-based (config numbering); -1: no fighter frames
  std::string character_name;
  double frame_time_s = 0;     ///< s, the BVH's
  bool truncated_last_line = false;
};

/// Writes what `options` asks for (atomically). `config` names the characters' BVH files.
/// Throws kumite::Error on bad input or when the interval holds no frame.
ExportReport export_log(const InstallationConfig& config, const ExportOptions& options);

}  // namespace kumite::app
