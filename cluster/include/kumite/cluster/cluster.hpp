#pragma once
// The render cluster: one master steps the frame and N render nodes draw the walls the
// installation file gives their machines, all showing the same frame at the same moment.
//
// Transport: ZeroMQ (libzmq + cppzmq, Debian). The master binds a PUB socket (`state`:
// STATE and GO to every node) and a ROUTER (`control`: HELLO, READY, BYE from the nodes;
// WELCOME, REFUSED, LEFT back). Each node connects a SUB and a DEALER whose routing id is
// "name#process" (its name and a random id of its process: a second process under a name whose
// process is in the barrier is refused, a node killed and restarted is welcomed back). Every message is one frame: a 40-byte header, then a payload:
//   u32 magic "KCL1", u16 protocol version, u8 type, u8 0, u64 config hash, u64 frame number,
//   f64 master time (s), u32 payload bytes, u32 0; little-endian.
// STATE's payload is the frame's whole state (never a delta: a node that joins late draws the
// next frame at once); what it holds is the caller's (app: the frame-state records).
//
// Swap barrier (as Vrui's, not SGCT's acknowledge-on-receipt): STATE(n) -> each node draws,
// finishes, READY(n) -> the master gathers READYs until every member's or a deadline (about
// two display periods) -> GO(n) -> every node swaps. A member that misses the deadline
// `max_misses` times in a row leaves the barrier (LEFT) and the others go on; its HELLO brings
// it back from the next frame. A node that hears no STATE for `master_lost_ms` is waiting for
// the master and says HELLO until a master welcomes it (a restarted master included).
// Messages that are cut, oversized, of another protocol version or of another installation
// file are counted and dropped; none stalls either side.
//
// This library knows nothing of the frame's content, of GL or of the installation's walls.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace kumite::cluster {

/// 3: the app's STATE carries the master's console (its texts, the spar planner's line among
/// them) beside the frame (2: a console without the planner's line; 1: none).
inline constexpr std::uint16_t kProtocolVersion = 3;
inline constexpr std::size_t kHeaderBytes = 40;
/// The most a payload may hold; larger messages are counted as oversized and dropped.
inline constexpr std::size_t kMaxPayloadBytes = 1u << 20;

// ---- configuration: [cluster] and its [[cluster.nodes]] in the installation file ------------

/// One render node: a machine (or a process) drawing some of the walls.
struct NodeConfig {
  std::string name;                       ///< unique, the node's `--node NAME` and routing id
  std::optional<std::string> address;     ///< its host, informational ("10.0.0.12")
  std::vector<std::string> walls;         ///< the walls it draws, by name (at least one)
  std::vector<std::string> windows;       ///< the windows it opens, by name (empty: those of its walls)
  /// A hardware swap group (GLX_NV_swap_group) its windows join, 1..16, where the driver offers
  /// one (none: not asked); `swap_barrier` (1..16, needs swap_group) binds the group to a swap
  /// barrier shared with other machines (a frame-lock board, e.g. Quadro Sync).
  std::optional<int> swap_group, swap_barrier;
  int line = 0;                           ///< the file's line of its [[cluster.nodes]] table
  bool operator==(const NodeConfig& o) const {
    return name == o.name && address == o.address && walls == o.walls && windows == o.windows &&
           swap_group == o.swap_group && swap_barrier == o.swap_barrier;
  }
};

struct ClusterConfig {
  std::string state;                      ///< endpoint of the master's PUB ("tcp://10.0.0.1:7700", "ipc:///run/kumite-state")
  std::string control;                    ///< endpoint of the master's ROUTER
  std::optional<std::string> state_bind;  ///< what the master binds, when not `state` ("tcp://*:7700")
  std::optional<std::string> control_bind;
  std::optional<double> deadline_ms;      ///< ms, READY gather deadline (default: two display periods)
  int max_misses = 3;                     ///< missed deadlines in a row that take a node out of the barrier
  double master_lost_ms = 500;            ///< ms without STATE after which a node waits for the master
  std::vector<NodeConfig> nodes;
  bool operator==(const ClusterConfig&) const = default;
  /// The node called `name` (nullptr: none).
  const NodeConfig* node(std::string_view name) const;
};

/// Reads [cluster] from an installation file's TOML text (nullopt: the file has none).
/// Throws kumite::Error("config", ...) "file:line: key: message": unknown keys, a missing
/// endpoint, an endpoint that is not tcp:// or ipc://, numbers not finite or out of range,
/// a node without a name or walls, a node named twice.
std::optional<ClusterConfig> parse_cluster_config(std::string_view text, std::string_view file);

// ---- messages --------------------------------------------------------------------------------

enum class MessageType : std::uint8_t {
  state = 1, go = 2, hello = 3, welcome = 4, ready = 5, bye = 6, refused = 7, left = 8,
};

struct Header {
  MessageType type = MessageType::state;
  std::uint64_t config_hash = 0;
  std::uint64_t frame = 0;
  double master_time_s = 0;
  std::uint32_t payload_bytes = 0;
};

/// What went wrong with a message received (counted, never thrown).
enum class Defect : std::uint8_t { none, cut, oversized, bad_magic, wrong_version, wrong_config, bad_type, not_finite };
std::string_view to_string(Defect d);

/// Writes header + payload into `out` (its room reused).
void encode_message(const Header& h, std::span<const std::byte> payload, std::string& out);
/// Reads a message: its header and payload (a view into `bytes`), or what is wrong with it.
/// `config_hash`: the installation file's; another is Defect::wrong_config (but for HELLO and
/// REFUSED, which carry the other side's hash to compare and say).
Defect decode_message(std::string_view bytes, std::uint64_t config_hash, Header& h, std::string_view& payload);

struct DefectCounts {
  std::uint64_t cut = 0, oversized = 0, bad_magic = 0, wrong_version = 0, wrong_config = 0, bad_type = 0, not_finite = 0;
  std::uint64_t total() const { return cut + oversized + bad_magic + wrong_version + wrong_config + bad_type + not_finite; }
  void count(Defect d);
};

// ---- the master ------------------------------------------------------------------------------

struct MasterOptions {
  ClusterConfig config;
  std::uint64_t config_hash = 0;  ///< the installation file's (every message carries it)
  double deadline_s = 1.0 / 30;   ///< s, READY gather deadline (config's deadline_ms, else two display periods)
};

/// One frame's barrier as the master saw it.
struct BarrierReport {
  std::uint64_t frame = 0;
  int members = 0;          ///< nodes in the barrier for this frame
  int ready = 0;            ///< of them, READY in time
  bool deadline_hit = false;
  double gather_s = 0;      ///< s, STATE published to GO published
  std::vector<std::string> left;     ///< nodes that left the barrier at this frame
};

struct MasterStats {
  std::uint64_t frames = 0;
  std::uint64_t state_bytes_last = 0, state_bytes_max = 0, state_bytes_total = 0;
  std::uint64_t deadlines_hit = 0;
  std::uint64_t joins = 0, leaves = 0, refusals = 0;
  DefectCounts defects;
};

class Master {
 public:
  /// Binds the sockets. Throws kumite::Error("cluster", "bind") naming the endpoint.
  explicit Master(MasterOptions options);
  ~Master();
  Master(const Master&) = delete;
  Master& operator=(const Master&) = delete;

  /// Publishes STATE(frame) with the frame's whole state (handles HELLOs waiting first).
  void publish(std::uint64_t frame, double master_time_s, std::span<const std::byte> state);
  /// Gathers READY(frame) from the barrier's members until all are in or the deadline
  /// (counted from publish()), then publishes GO(frame). Handles HELLO and BYE meanwhile.
  const BarrierReport& release();
  /// The nodes now in the barrier.
  std::vector<std::string> members() const;
  const MasterStats& stats() const;
  /// One line per event since the last call ("node front joined", "node left left the
  /// barrier: 3 deadlines missed", "node x refused: ..."): the console's and the log's.
  std::vector<std::string> take_events();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---- a render node ---------------------------------------------------------------------------

struct NodeOptions {
  ClusterConfig config;
  std::string name;
  std::uint64_t config_hash = 0;
  /// s: how long a node waits for GO after its READY before it shows the frame anyway.
  double go_timeout_s = 0.1;
  std::size_t timing_capacity = 1u << 16;  ///< frames whose NodeTiming is kept
};

/// When one frame reached this node and left it (s, the node's steady clock: on one machine
/// the same clock for every node, so the skew between nodes is a difference of these).
struct NodeTiming {
  std::uint64_t frame = 0;
  double master_time_s = 0;
  double state_rx_s = 0;   ///< STATE received
  double ready_tx_s = 0;   ///< READY sent (after drawing and finishing)
  double go_rx_s = -1;     ///< released by GO (-1: no GO in time)
  std::uint32_t state_bytes = 0;
};

struct NodeStats {
  std::uint64_t states = 0, skipped = 0;  ///< STATEs taken; older ones dropped for a newer
  std::uint64_t gos = 0, go_timeouts = 0;
  std::uint64_t welcomes = 0, lefts = 0, hellos = 0;
  std::uint64_t master_lost = 0;          ///< times it started waiting for the master
  DefectCounts defects;
};

class Node {
 public:
  /// Connects (ZeroMQ connects lazily: no master needed yet) and says HELLO. Throws
  /// kumite::Error("cluster", "node") when `name` is not one of the config's nodes.
  explicit Node(NodeOptions options);
  ~Node();  ///< says BYE
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  enum class Wait : std::uint8_t { state, timeout, refused };
  /// Waits up to `timeout_s` for the newest STATE (older ones queued behind it are skipped).
  /// Wait::state: state_header() and state() hold it until the next call.
  Wait next_state(double timeout_s);
  const Header& state_header() const;
  std::string_view state() const;
  /// The frame is drawn and finished: READY(frame).
  void ready();
  /// Waits for GO of the frame taken (up to go_timeout_s); true: released by it.
  bool wait_go();
  /// No STATE for master_lost_ms: the master is gone (or not started); HELLO is being said.
  bool waiting_for_master() const;
  bool in_barrier() const;  ///< welcomed and not left
  /// Set when the master refused this node: one line saying why (another config, unknown name).
  const std::optional<std::string>& refused() const;
  const NodeStats& stats() const;
  /// Every frame's timing so far, in order (room for `timing_capacity` frames reserved up
  /// front, so that keeping them allocates nothing per frame; later frames are counted in
  /// timings_dropped(), not kept).
  const std::vector<NodeTiming>& timings() const;
  std::uint64_t timings_dropped() const;
  std::vector<std::string> take_events();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The installation file's hash that travels with every message: FNV-1a 64 of its bytes.
std::uint64_t config_hash(std::string_view file_text);

}  // namespace kumite::cluster
