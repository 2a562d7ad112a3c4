// A render node: the newest STATE, READY when drawn, GO to swap; HELLO until welcomed.
#include <random>
#include <utility>

#include <unistd.h>

#include <fmt/format.h>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/error.hpp"
#include "sockets.hpp"

namespace kumite::cluster {

namespace {
/// s between HELLOs while not in the barrier.
constexpr double kHelloInterval_s = 0.1;
}  // namespace

struct Node::Impl {
  NodeOptions opt;
  zmq::context_t ctx{1};
  zmq::socket_t sub{ctx, zmq::socket_type::sub};
  zmq::socket_t dealer{ctx, zmq::socket_type::dealer};
  zmq::message_t msg;
  std::string state, pending, out;  // the frame taken; a newer one met while waiting for GO
  Header state_h, pending_h;
  bool has_pending = false;
  std::uint64_t latest_go = 0;
  bool any_go = false;
  bool welcomed = false, waiting = false;
  Timestamp last_state = 0, last_hello = -1e9, started = 0;
  std::optional<std::string> refused;
  NodeStats stats;
  std::vector<NodeTiming> timings;
  std::uint64_t timings_dropped = 0;
  std::vector<std::string> events;

  explicit Impl(NodeOptions o) : opt(std::move(o)) {
    if (!opt.config.node(opt.name)) {
      std::string known;
      for (const auto& n : opt.config.nodes) known += (known.empty() ? "" : ", ") + n.name;
      throw Error("cluster", "node", fmt::format("--node {}: not a node of the installation file (its nodes: {})", opt.name, known));
    }
    detail::common_options(sub, false);
    detail::common_options(dealer, true);
    sub.set(zmq::sockopt::rcvhwm, 8);
    sub.set(zmq::sockopt::subscribe, "");
    // The routing id: the node's name and this process's id, so that the master tells a second
    // process under a name in use from the node coming back (killed and restarted, continued).
    std::random_device rd;
    const std::uint64_t instance = (static_cast<std::uint64_t>(rd()) << 32) ^ rd() ^ static_cast<std::uint64_t>(getpid());
    dealer.set(zmq::sockopt::routing_id, fmt::format("{}#{:016x}", opt.name, instance));
    dealer.set(zmq::sockopt::immediate, 1);  // nothing queued for a master not there
    dealer.set(zmq::sockopt::sndhwm, 16);
    try {
      sub.connect(opt.config.state);
      dealer.connect(opt.config.control);
    } catch (const zmq::error_t& e) {
      throw Error("cluster", "connect", fmt::format("node {}: cannot connect {} / {}: {}", opt.name, opt.config.state,
                                                    opt.config.control, e.what()));
    }
    timings.reserve(opt.timing_capacity);
    started = last_state = now();
    hello();
  }

  void send(MessageType type, std::uint64_t frame) {
    encode_message({type, opt.config_hash, frame, 0, 0}, {}, out);
    (void)dealer.send(zmq::buffer(out), zmq::send_flags::dontwait);
  }
  void hello() {
    send(MessageType::hello, 0);
    last_hello = now();
    ++stats.hellos;
  }

  /// Takes every message `socket` holds, each one read (its defects counted and dropped) and
  /// handed to `on(header, payload)`.
  template <typename F>
  void receive(zmq::socket_t& socket, F&& on) {
    while (detail::try_recv(socket, msg)) {
      Header h;
      std::string_view payload;
      const Defect d = decode_message(msg.to_string_view(), opt.config_hash, h, payload);
      if (d != Defect::none) stats.defects.count(d);
      else on(h, payload);
    }
  }

  void control() {
    receive(dealer, [this](const Header& h, std::string_view payload) {
      switch (h.type) {
        case MessageType::welcome:
          if (!welcomed) events.push_back(fmt::format("node {}: in the barrier", opt.name));
          welcomed = true;
          ++stats.welcomes;
          break;
        case MessageType::refused:
          refused = std::string(payload);
          events.push_back(*refused);
          break;
        case MessageType::left:
          if (welcomed) events.push_back(fmt::format("node {}: out of the barrier (deadlines missed): HELLO again", opt.name));
          welcomed = false;
          ++stats.lefts;
          hello();
          break;
        default: stats.defects.count(Defect::bad_type); break;
      }
    });
  }

  /// Reads what the SUB socket holds: the newest STATE into `pending`, GO frames into latest_go.
  void drain() {
    receive(sub, [this](const Header& h, std::string_view payload) {
      if (h.type == MessageType::state) {
        if (has_pending) ++stats.skipped;
        pending.assign(payload);  // room reused
        pending_h = h;
        has_pending = true;
        last_state = now();
      } else if (h.type == MessageType::go) {
        if (!any_go || h.frame > latest_go) latest_go = h.frame;
        any_go = true;
      } else {
        stats.defects.count(Defect::bad_type);
      }
    });
  }

  void keep_in_touch() {
    const Timestamp t = now();
    if (!waiting && t - last_state > opt.config.master_lost_ms * 1e-3) {
      waiting = true;
      welcomed = false;  // a master that comes back knows nothing of this node
      ++stats.master_lost;
      events.push_back(fmt::format("node {}: waiting for master (no state for {:.0f} ms from {})", opt.name,
                                   (t - last_state) * 1e3, opt.config.state));
    }
    if (!welcomed && !refused && t - last_hello >= kHelloInterval_s) hello();
  }

  void poll(double seconds) {
    zmq::pollitem_t items[2] = {{sub.handle(), 0, ZMQ_POLLIN, 0}, {dealer.handle(), 0, ZMQ_POLLIN, 0}};
    detail::poll(items, 2, detail::poll_ms(seconds));
  }
};

Node::Node(NodeOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

Node::~Node() {
  try {
    impl_->send(MessageType::bye, 0);
  } catch (...) {
  }
}

Node::Wait Node::next_state(double timeout_s) {
  auto& n = *impl_;
  const Timestamp deadline = now() + timeout_s;
  for (;;) {
    n.control();
    if (n.refused) return Wait::refused;
    n.drain();
    if (n.has_pending) {
      std::swap(n.state, n.pending);
      n.state_h = n.pending_h;
      n.has_pending = false;
      ++n.stats.states;
      if (n.waiting) n.events.push_back(fmt::format("node {}: master back at frame {}", n.opt.name, n.state_h.frame));
      n.waiting = false;
      if (n.timings.size() < n.timings.capacity())
        n.timings.push_back({n.state_h.frame, n.state_h.master_time_s, n.last_state, -1, -1,
                             static_cast<std::uint32_t>(n.state.size() + kHeaderBytes)});
      else
        ++n.timings_dropped;
      n.keep_in_touch();
      return Wait::state;
    }
    n.keep_in_touch();
    const double left = deadline - now();
    if (left <= 0) return Wait::timeout;
    n.poll(std::min(left, 0.05));
  }
}

const Header& Node::state_header() const { return impl_->state_h; }
std::string_view Node::state() const { return impl_->state; }

void Node::ready() {
  auto& n = *impl_;
  // Out of the barrier the master waits for no READY: HELLO (keep_in_touch) brings it back.
  // The time before the send: after it, the GO it completes may already be out.
  if (!n.timings.empty() && n.timings.back().frame == n.state_h.frame) n.timings.back().ready_tx_s = now();
  if (n.welcomed) n.send(MessageType::ready, n.state_h.frame);
}

bool Node::wait_go() {
  auto& n = *impl_;
  const std::uint64_t frame = n.state_h.frame;
  const Timestamp deadline = now() + n.opt.go_timeout_s;
  bool released = false;
  for (;;) {
    n.drain();
    if (n.any_go && n.latest_go >= frame) {
      released = true;
      break;
    }
    // A newer STATE already here: its GO was lost (a backlog dropped): show now.
    if (n.has_pending && n.pending_h.frame > frame) break;
    const double left = deadline - now();
    if (left <= 0) break;
    zmq::pollitem_t item{n.sub.handle(), 0, ZMQ_POLLIN, 0};
    detail::poll(&item, 1, detail::poll_ms(std::min(left, 0.001)));
  }
  const Timestamp t = now();
  if (released) ++n.stats.gos;
  else ++n.stats.go_timeouts;
  if (!n.timings.empty() && n.timings.back().frame == frame) n.timings.back().go_rx_s = released ? t : -1;
  n.control();
  return released;
}

bool Node::waiting_for_master() const { return impl_->waiting; }
bool Node::in_barrier() const { return impl_->welcomed; }
const std::optional<std::string>& Node::refused() const { return impl_->refused; }
const NodeStats& Node::stats() const { return impl_->stats; }
const std::vector<NodeTiming>& Node::timings() const { return impl_->timings; }
std::uint64_t Node::timings_dropped() const { return impl_->timings_dropped; }
std::vector<std::string> Node::take_events() { return std::exchange(impl_->events, {}); }

}  // namespace kumite::cluster
