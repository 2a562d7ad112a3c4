#include "kumite/app/cluster_source.hpp"

#include <algorithm>
#include <cstdio>
#include <set>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "kumite/app/scene.hpp"
#include "kumite/common/error.hpp"

namespace kumite::app {

namespace {
/// Frames whose times a run keeps for its timing log (about 2 h at 120 Hz); later ones are
/// counted, not kept.
constexpr std::size_t kTimingRows = 1u << 20;

const cluster::ClusterConfig& cluster_of(const InstallationConfig& c) {
  if (!c.cluster)
    throw Error("cluster", "config", fmt::format("{}: no [cluster] table: a render node needs the cluster's file",
                                                 c.file.string()));
  return *c.cluster;
}

/// The walls no node draws: the master's own.
std::vector<std::string> master_walls(const InstallationConfig& c) {
  std::set<std::string> taken;
  for (const auto& n : cluster_of(c).nodes) taken.insert(n.walls.begin(), n.walls.end());
  std::vector<std::string> out;
  for (const auto& w : c.walls)
    if (!taken.contains(w.name)) out.push_back(w.name);
  return out;
}

const cluster::NodeConfig& node_of(const InstallationConfig& c, const std::string& name) {
  const auto* n = cluster_of(c).node(name);
  if (!n) {
    std::string known;
    for (const auto& x : c.cluster->nodes) known += (known.empty() ? "" : ", ") + x.name;
    throw Error("cluster", "node", fmt::format("--node {}: {} has no such node (its nodes: {})", name, c.file.string(), known));
  }
  return *n;
}

double deadline_s(const InstallationConfig& c) {
  const auto& cl = cluster_of(c);
  return cl.deadline_ms ? *cl.deadline_ms * 1e-3 : 2.0 / c.display_rate_hz;
}

std::FILE* open_log(const std::optional<std::filesystem::path>& p) {
  if (!p) return nullptr;
  std::FILE* f = std::fopen(p->c_str(), "w");
  if (!f) spdlog::error("cluster: cannot write the timing log {}", p->string());
  return f;
}
}  // namespace

// ---- the walls one process draws ----------------------------------------------------------

WallSubset::WallSubset(const InstallationConfig& full, const std::vector<std::string>& walls,
                       const std::vector<std::string>& windows)
    : config_(full) {
  config_.walls.clear();
  std::set<std::string> used_windows(windows.begin(), windows.end());
  for (std::size_t i = 0; i < full.walls.size(); ++i) {
    if (std::find(walls.begin(), walls.end(), full.walls[i].name) == walls.end()) continue;
    WallConfig w = full.walls[i];
    // "" is the file's first window: named, so that it stays that one among fewer windows.
    if (w.window.empty() && !full.windows.empty()) w.window = full.windows[0].name;
    if (windows.empty() && !w.window.empty()) used_windows.insert(w.window);
    index_.push_back(i);
    walls_.push_back(wall_frame(w));
    config_.walls.push_back(std::move(w));
  }
  config_.windows.clear();
  for (const auto& w : full.windows)
    if (used_windows.contains(w.name)) config_.windows.push_back(w);
  // A wall whose window this process does not open is shown in its first one.
  for (auto& w : config_.walls)
    if (std::none_of(config_.windows.begin(), config_.windows.end(), [&](const WindowConfig& x) { return x.name == w.window; })) {
      w.window.clear();
      w.viewport.reset();
    }
}

const FrameData& WallSubset::apply(const FrameData& full) {
  frame_ = full;  // copy-assignment: the vectors' room is reused
  apply_in_place(frame_);
  return frame_;
}

void WallSubset::apply_in_place(FrameData& f) const {
  // Indices rise and index_[k] >= k: moving down in place never overwrites one still needed.
  for (std::size_t k = 0; k < index_.size(); ++k)
    if (index_[k] < f.views.size()) f.views[k] = f.views[index_[k]];
  f.views.resize(std::min(index_.size(), f.views.size()));
}

// ---- the master ---------------------------------------------------------------------------

ClusterMasterSource::ClusterMasterSource(Installation& inst, LivePacing pacing, ClusterRunOptions options)
    : live_(inst, pacing), subset_(inst.config(), master_walls(inst.config())), options_(std::move(options)) {
  const auto& c = inst.config();
  cluster::MasterOptions mo;
  mo.config = cluster_of(c);
  mo.config_hash = c.file_hash;
  mo.deadline_s = deadline_s(c);
  master_ = std::make_unique<cluster::Master>(std::move(mo));
  if (options_.timing_log) rows_.reserve(kTimingRows);
  spdlog::info("cluster master: state {} control {}; {} nodes; READY deadline {:.1f} ms; draws {} of the {} walls here",
               c.cluster->state, c.cluster->control, c.cluster->nodes.size(), deadline_s(c) * 1e3,
               subset_.config().walls.size(), c.walls.size());
}

const FrameData* ClusterMasterSource::next() {
  const FrameData* f = live_.next();
  if (!f) return nullptr;
  // The whole frame, its skeleton and the console's texts included: no deltas.
  encode_frame_state(*f, live_.console(*f), bytes_);
  frame_ = f->frame;
  master_->publish(f->frame, f->now, std::as_bytes(std::span(bytes_.data(), bytes_.size())));
  published_ = now();
  return &subset_.apply(*f);
}

void ClusterMasterSource::drawn() {
  live_.drawn();
  const auto& r = master_->release();
  for (const auto& e : master_->take_events()) spdlog::info("cluster: {}", e);
  const auto& s = master_->stats();
  if (options_.timing_log && rows_.size() < rows_.capacity())
    rows_.push_back({frame_, published_, r.gather_s * 1e3, r.members, r.ready, r.deadline_hit,
                     static_cast<std::uint32_t>(s.state_bytes_last)});
}

ClusterMasterSource::~ClusterMasterSource() {
  const auto& s = master_->stats();
  spdlog::info("cluster master: {} frames sent, {} bytes/frame (max {}, mean {:.0f}), {} deadlines hit, {} joins, {} "
               "leaves, {} refused, {} bad messages",
               s.frames, s.state_bytes_last, s.state_bytes_max,
               s.frames ? static_cast<double>(s.state_bytes_total) / static_cast<double>(s.frames) : 0.0, s.deadlines_hit,
               s.joins, s.leaves, s.refusals, s.defects.total());
  if (std::FILE* f = open_log(options_.timing_log)) {
    std::fprintf(f, "frame,publish_s,members,ready,deadline_hit,gather_ms,bytes\n");
    for (const auto& r : rows_)
      std::fprintf(f, "%llu,%.6f,%d,%d,%d,%.3f,%u\n", static_cast<unsigned long long>(r.frame), r.published_s, r.members,
                   r.ready, r.deadline_hit ? 1 : 0, r.gather_ms, r.bytes);
    std::fclose(f);
  }
}

// ---- a render node ------------------------------------------------------------------------

ClusterNodeSource::ClusterNodeSource(const InstallationConfig& c, const std::string& name, ClusterRunOptions options)
    : name_(name),
      subset_(c, node_of(c, name).walls, node_of(c, name).windows),
      options_(std::move(options)) {
  cluster::NodeOptions no;
  no.config = cluster_of(c);
  no.name = name;
  no.config_hash = c.file_hash;
  no.go_timeout_s = std::max(0.1, 4.0 / c.display_rate_hz);
  no.timing_capacity = options_.timing_log ? kTimingRows : 1024;
  node_ = std::make_unique<cluster::Node>(std::move(no));
  spdlog::info("cluster node {}: draws {} wall(s) from {} (control {})", name, subset_.config().walls.size(),
               c.cluster->state, c.cluster->control);
}

const FrameData* ClusterNodeSource::next() {
  repeated_ = false;
  for (;;) {
    if (options_.stop && options_.stop->load() != 0) return nullptr;
    const auto w = node_->next_state(options_.repeat_while_waiting ? options_.repeat_s : 0.1);
    for (const auto& e : node_->take_events()) spdlog::info("cluster: {}", e);
    if (w == cluster::Node::Wait::refused) throw Error("cluster", "refused", *node_->refused());
    if (w != cluster::Node::Wait::state) {
      // The walls say that the master is gone: the last picture with the notice over it (the
      // windows' events handled meanwhile), every repeat_s in windows, once per wait headless.
      if (node_->waiting_for_master() && (options_.repeat_while_waiting || !notice_shown_)) {
        if (!have_frame_) empty_room();
        notice_shown_ = true;
        repeated_ = true;
        return &frame_;
      }
      continue;
    }
    notice_shown_ = false;
    if (!decoder_.decode(node_->state(), frame_, &console_)) {
      if (undecodable_++ == 0)
        spdlog::warn("cluster node {}: frame {}: its state does not read ({}): skipped (counted)", name_,
                     node_->state_header().frame, decoder_.problem());
      continue;
    }
    have_console_ = decoder_.has_console();
    console_problem_.clear();
    if (!have_console_) {
      console_problem_ = decoder_.console_problem().empty() ? "the master sent no console with its frame"
                                                            : "the master's console does not read: " + decoder_.console_problem();
      if (bad_console_++ == 0)
        spdlog::warn("cluster node {}: frame {}: {}: its frame drawn, its console made from the frame alone (counted)",
                     name_, node_->state_header().frame, console_problem_);
    }
    subset_.apply_in_place(frame_);
    have_frame_ = true;
    return &frame_;
  }
}

std::string_view ClusterNodeSource::notice() const {
  return node_->waiting_for_master() ? "waiting for master" : std::string_view{};
}

void ClusterNodeSource::empty_room() {
  // No frame of a master's yet: the room as it stands, seen from the default head.
  const InstallationConfig& c = subset_.config();
  frame_ = FrameData{};
  have_console_ = false;
  console_problem_.clear();
  frame_.head.position = {c.viewer.default_head_m[0], c.viewer.default_head_m[1], c.viewer.default_head_m[2]};
  const auto& off = c.viewer.eye_offset_m;
  frame_.eyes = eyes_from_head(frame_.head, c.viewer.interpupillary_distance_m, {off[0], off[1], off[2]});
  plan_views(subset_.walls(), frame_.eyes, c.projection.near_m, c.projection.far_m, frame_.views);
}

ConsoleState ClusterNodeSource::console(const FrameData& f) const {
  // The master's console for this frame (its texts, its problems), the node's problems added.
  // (`f` is the frame handed out last: the one the console came with.)
  if (have_console_ && &f == &frame_) {
    ConsoleState c = console_;
    node_problems(c);
    return c;
  }
  ConsoleState c;
  c.fighter_state = f.fighter.present ? std::string(content::to_string(f.fighter.state)) : "none";
  c.character = f.fighter.character;
  if (const auto& chars = subset_.config().characters; f.fighter.character >= 0 &&
                                                       f.fighter.character < static_cast<int>(chars.size()))
    c.character_name = chars[static_cast<std::size_t>(f.fighter.character)].name;
  c.head_live = f.head_live;
  c.pose_age_ms = f.pose_age_ms;
  c.latch_ms = f.latch_ms;
  if (!console_problem_.empty() && &f == &frame_) c.problems.push_back(console_problem_);
  node_problems(c);
  return c;
}

void ClusterNodeSource::node_problems(ConsoleState& c) const {
  if (node_->waiting_for_master()) c.problems.push_back("waiting for master");
  if (!node_->in_barrier()) c.problems.push_back("not in the swap barrier");
}

void ClusterNodeSource::drawn() {
  if (repeated_) return;  // not a frame of the master's: no READY, no GO
  node_->ready();
  node_->wait_go();
}

ClusterNodeSource::~ClusterNodeSource() {
  const auto& s = node_->stats();
  spdlog::info("cluster node {}: {} states ({} skipped for newer, {} undecodable, {} without a console that reads), {} "
               "released by GO, {} GO timeouts, {} times out of the barrier, {} bad messages",
               name_, s.states, s.skipped, undecodable_, bad_console_, s.gos, s.go_timeouts, s.lefts, s.defects.total());
  if (std::FILE* f = open_log(options_.timing_log)) {
    std::fprintf(f, "frame,master_time_s,state_rx_s,ready_tx_s,go_rx_s,bytes\n");
    for (const auto& t : node_->timings())
      std::fprintf(f, "%llu,%.6f,%.6f,%.6f,%.6f,%u\n", static_cast<unsigned long long>(t.frame), t.master_time_s,
                   t.state_rx_s, t.ready_tx_s, t.go_rx_s, t.state_bytes);
    std::fclose(f);
  }
}

}  // namespace kumite::app
