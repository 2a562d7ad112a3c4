#pragma once
// kumite export: a run judged and reused from its log alone. Reads a frames.jsonl and writes
// the fighter's performance over [from_s, to_s] as BVH on the character's own skeleton (the
// logged local rotations and root joint, written as they are: no retargeting, no fitting),
// and the visitor's head poses as CSV.
//
// One BVH frame per logged frame; the BVH's frame time is the mean interval of those frames
// (a run in simulated time logs exact steps; a real-time run's late frames are not
// resampled). An interval that holds a character switch is written as one BVH per character
// run (a skeleton per BVH), beside --out: `fighter.bvh` -> `fighter.01-kenji.bvh`,
// `fighter.02-mei.bvh`, ... (run_bvh_path), each on its character's skeleton from its first
// frame as that character; an interval of one character writes --out itself. Bad input (a line that is not JSON, a missing or non-finite number, a joint the
// character's skeleton lacks) throws kumite::Error "file:line: key: message"; a last line cut
// short (a run killed mid-write) is left out with a warning.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "kumite/app/config.hpp"

namespace kumite::app {

struct ExportOptions {
  std::filesystem::path log;                    ///< frames.jsonl
  double from_s = 0;                            ///< s, time_s of the first frame taken (inclusive)
  double to_s = 1e300;                          ///< s, time_s of the last frame taken (inclusive)
  std::optional<std::filesystem::path> bvh;     ///< the fighter's performance (needs the config)
  std::optional<std::filesystem::path> head_csv;///< frame,time_s,x,y,z,qw,qx,qy,qz,live
};

/// One character's stretch of the interval, written as one BVH.
struct ExportRun {
  int character = -1;          ///< 0-based (config numbering)
  std::string character_name;
  int first_frame = -1, last_frame = -1, frames = 0;
  double first_time_s = 0, last_time_s = 0;  ///< s, time_s of its first and last frames
  double frame_time_s = 0;     ///< s, its BVH's (the mean interval of its frames)
  std::filesystem::path bvh;   ///< where it was written
};

struct ExportReport {
  int frames = 0;              ///< logged frames in the interval
  int first_frame = -1, last_frame = -1;
  double first_time_s = 0, last_time_s = 0;
  int character = -1;          ///< 0-based (config numbering), the first run's; -1: no BVH asked for
  std::string character_name;  ///< the first run's
  double frame_time_s = 0;     ///< s, the first run's BVH's
  std::vector<ExportRun> runs; ///< with a BVH asked for: one per character run, in order
  bool truncated_last_line = false;
};

/// The BVH of the interval's run `index` (0-based) when it holds more than one:
/// `dir/fighter.bvh` -> `dir/fighter.01-kenji.bvh` (characters outside [A-Za-z0-9_-] as `_`).
std::filesystem::path run_bvh_path(const std::filesystem::path& bvh, int index, const std::string& character_name);

/// Writes what `options` asks for (atomically). `config` names the characters' BVH files.
/// Throws kumite::Error on bad input or when the interval holds no frame.
ExportReport export_log(const InstallationConfig& config, const ExportOptions& options);

}  // namespace kumite::app
