// wand sub-command: wand length over the volume, and an optional refinement of the poses.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/calibration/commands.hpp"
#include "kumite/calibration/wand.hpp"
#include "kumite/common/atomic_file.hpp"
#include "kumite/common/error.hpp"
#include "kumite/tracking/calibration_file.hpp"

namespace kumite::calibration {

void run_wand(const WandCommand& cmd) {
  if (!(cmd.wand_length_m > 0.05 && cmd.wand_length_m < 5)) {
    throw Error("calibration", "args", "--length must be the wand's marker distance in metres (0.05 .. 5)");
  }
  const tracking::RigCalibration rig = tracking::read_calibration(cmd.calibration);
  WandOptions opt;
  opt.length_m = cmd.wand_length_m;
  opt.blobs.threshold = cmd.blob_threshold;
  opt.progress = [](const std::string& s) { spdlog::info("{}", s); };
  WandResult r = measure_wand(rig, cmd.recording_dir, opt);
  const auto& s = r.stats;
  spdlog::info("wand length over {} frames: mean {:.2f} mm (true {:.2f} mm), spread (std) {:.2f} mm, min {:.2f} max {:.2f} mm",
               s.samples, s.mean_m * 1000, cmd.wand_length_m * 1000, s.std_m * 1000, s.min_m * 1000, s.max_m * 1000);
  for (const auto& g : r.regions) {
    spdlog::info("  around ({:.1f}, {:.1f}, {:.1f}) m: {} frames, mean {:.2f} mm, std {:.2f} mm", g.centre[0], g.centre[1],
                 g.centre[2], g.stats.samples, g.stats.mean_m * 1000, g.stats.std_m * 1000);
  }
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    spdlog::info("  {}: {} wand blobs, reprojection RMS {:.2f} px{}", rig.cameras[c].name, r.camera_blobs[c],
                 r.camera_rms_px[c], r.camera_rms_px[c] > 1.0 ? "  <- this camera disagrees: it moved or its calibration is off" : "");
  }
  if (cmd.refine_out) {
    refine_with_wand(rig, opt, r);
    spdlog::info("after refinement: mean {:.2f} mm, std {:.2f} mm, RMS error {:.2f} mm (before {:.2f} mm)",
                 r.refined_stats.mean_m * 1000, r.refined_stats.std_m * 1000, r.refined_stats.rms_error_m * 1000,
                 s.rms_error_m * 1000);
    const fs::path backup = keep_previous_version(*cmd.refine_out);
    if (!backup.empty()) spdlog::info("kept the previous calibration as {}", backup.string());
    tracking::write_calibration(*cmd.refine_out, *r.refined);
    spdlog::info("wrote {}", cmd.refine_out->string());
  }
  if (cmd.out_json) {
    write_file_atomically(*cmd.out_json, wand_json(cmd, r));
    spdlog::info("wrote {}", cmd.out_json->string());
  }
}

}  // namespace kumite::calibration
