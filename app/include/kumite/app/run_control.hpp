#pragma once
// What every run shares around its frame loop, GL-free (kumite::app_core): stopping on
// SIGINT/SIGTERM, output folders made (or refused) before a run starts, the retrieval
// timing line at the end, whether a display is there.
#include <atomic>
#include <filesystem>
#include <string_view>

namespace kumite::app {

class Installation;

/// From the first call on, SIGINT and SIGTERM no longer kill the process: they store their
/// number in the returned flag (pass it as the options' `stop`), so the run ends at its next
/// frame with its outputs complete. A second such signal kills the process at once (a run
/// stuck in start-up or in a driver can still be interrupted).
const std::atomic<int>& stop_on_signals();

/// Creates `dir` and its missing parents (or checks an existing one is writable), else throws
/// kumite::Error("io", "folder") in one line: "<what>: <why>" (`what` e.g. "--out out/x",
/// why: a file in the way, no permission).
void make_output_folder(const std::filesystem::path& dir, std::string_view what);

/// One line at the end of a run: strike plans asked for, and how many updates had to wait
/// for the retrieval worker (content::kRetrievalDelayUpdates).
void log_retrieval_timing(const Installation& installation);
/// One line at the end of a run that sparred (and when spar mode is left): the round's score.
void log_spar_summary(const Installation& installation);

/// Whether a display is there to open windows on ($DISPLAY or $WAYLAND_DISPLAY).
bool display_available();

}  // namespace kumite::app
