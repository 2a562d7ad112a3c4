#pragma once
// The installation as a render cluster ([cluster] in the installation file, kumite::cluster):
//   ClusterMasterSource  the live step on the master: each frame's whole state sent to the
//                        nodes (the frame-state records, frame_states.hpp), the master's own
//                        walls (those no node draws) drawn, the nodes' READYs gathered, GO.
//   ClusterNodeSource    a render node (`kumite --node NAME`): the master's frames, its walls
//                        drawn from them alone, READY when finished, shown on GO.
// Both are FrameSources: the same presenter loops (run.hpp) draw them.
#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kumite/app/frame_source.hpp"
#include "kumite/app/frame_states.hpp"
#include "kumite/app/projection.hpp"
#include "kumite/cluster/cluster.hpp"

namespace kumite::app {

/// The walls (and their windows) one process of a cluster draws, and a frame cut down to them.
class WallSubset {
 public:
  /// `walls`: by name, in the file's order kept; `windows`: by name (empty: the windows those
  /// walls are in).
  WallSubset(const InstallationConfig& full, const std::vector<std::string>& walls,
             const std::vector<std::string>& windows = {});
  /// The installation file with only these walls and windows.
  const InstallationConfig& config() const { return config_; }
  std::span<const WallFrame> walls() const { return walls_; }
  /// `full` with the views of these walls only (a copy kept here; its room reused).
  const FrameData& apply(const FrameData& full);
  /// The same, in place.
  void apply_in_place(FrameData& frame) const;

 private:
  InstallationConfig config_;
  std::vector<std::size_t> index_;  ///< wall indices in the full file
  std::vector<WallFrame> walls_;
  FrameData frame_;
};

/// What a cluster run keeps of its frames for the figures (bytes per frame, times).
struct ClusterRunOptions {
  /// CSV of every frame's times (the master: its barrier; a node: STATE received, READY sent,
  /// GO received), written at the end; none: not written.
  std::optional<std::filesystem::path> timing_log;
  /// The run ends at its next frame when this is non-zero (a node waiting for its master too).
  const std::atomic<int>* stop = nullptr;
  /// A node waiting for its master hands its last frame (before any: the empty room from the
  /// default head) again every `repeat_s`, "waiting for master" across its walls (windows: they
  /// stay responsive and keep their picture); false: once per wait, then it waits inside next()
  /// (headless: one picture of the walls saying so).
  bool repeat_while_waiting = false;
  double repeat_s = 0.1;
};

class ClusterMasterSource final : public FrameSource {
 public:
  /// Binds the cluster's sockets (kumite::Error "cluster" when it cannot).
  ClusterMasterSource(Installation& installation, LivePacing pacing, ClusterRunOptions options = {});
  ~ClusterMasterSource() override;
  const InstallationConfig& config() const override { return subset_.config(); }
  std::span<const WallFrame> walls() const override { return subset_.walls(); }
  void begin() override { live_.begin(); }
  const FrameData* next() override;
  ConsoleState console(const FrameData& frame) const override { return live_.console(frame); }
  void drawn() override;
  void shown(Timestamp at) override { live_.shown(at); }
  bool wait_for_gpu() const override { return true; }
  Installation* orders() override { return live_.orders(); }
  const Installation* installation() const override { return live_.installation(); }
  bool ending() const override { return live_.ending(); }
  bool close_asked(Timestamp at) override { return live_.close_asked(at); }
  const cluster::Master& master() const { return *master_; }

 private:
  LiveSource live_;
  WallSubset subset_;
  ClusterRunOptions options_;
  std::unique_ptr<cluster::Master> master_;
  std::string bytes_;
  struct Row {
    std::uint64_t frame;
    double published_s, gather_ms;
    int members, ready;
    bool deadline_hit;
    std::uint32_t bytes;
  };
  std::vector<Row> rows_;  ///< reserved up front
  std::uint64_t frame_ = 0;
  Timestamp published_ = 0;
};

class ClusterNodeSource final : public FrameSource {
 public:
  /// Connects as node `name` of the file's [cluster] (kumite::Error "cluster" when the file has
  /// no cluster or no such node). No master is needed yet: it is waited for.
  ClusterNodeSource(const InstallationConfig& config, const std::string& name, ClusterRunOptions options = {});
  ~ClusterNodeSource() override;
  const InstallationConfig& config() const override { return subset_.config(); }
  std::span<const WallFrame> walls() const override { return subset_.walls(); }
  /// The master's next frame (waits for it; when none comes for master_lost_ms, the last frame
  /// again with notice() "waiting for master", see ClusterRunOptions::repeat_while_waiting);
  /// nullptr when stopped. Throws kumite::Error("cluster", "refused") with the master's one
  /// line when it refuses this node (another installation file).
  const FrameData* next() override;
  ConsoleState console(const FrameData& frame) const override;
  void drawn() override;
  bool wait_for_gpu() const override { return true; }
  bool repeated() const override { return repeated_; }
  /// "waiting for master" while the node waits for one; empty otherwise.
  std::string_view notice() const override;
  const cluster::Node& node() const { return *node_; }
  /// Frames whose state could not be read (damaged records): counted, skipped.
  std::uint64_t undecodable() const { return undecodable_; }
  /// Frames drawn whose master's console did not come or did not read (a cut or malformed
  /// text): their console made from the frame alone, with a problem saying so; counted.
  std::uint64_t bad_console() const { return bad_console_; }

 private:
  void empty_room();  ///< frame_: the room without a fighter, from the default head
  void node_problems(ConsoleState& c) const;  ///< "waiting for master", "not in the swap barrier"
  std::string name_;
  WallSubset subset_;
  ClusterRunOptions options_;
  std::unique_ptr<cluster::Node> node_;
  FrameStateDecoder decoder_;
  FrameData frame_;
  ConsoleState console_;        ///< the master's console for frame_ (when have_console_)
  bool have_console_ = false;
  std::string console_problem_;  ///< why frame_ came without a console that reads ("" if it did)
  bool have_frame_ = false;
  bool repeated_ = false;  ///< the frame handed out is the last one again (no READY for it)
  bool notice_shown_ = false;  ///< this wait for the master has been shown on the walls
  std::uint64_t undecodable_ = 0, bad_console_ = 0;
};

}  // namespace kumite::app
