// The master: STATE to every node, READY gathered with a deadline, GO.
#include <algorithm>
#include <map>
#include <utility>

#include <fmt/format.h>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/error.hpp"
#include "sockets.hpp"

namespace kumite::cluster {

struct Master::Impl {
  struct Member {
    bool active = false;
    int misses = 0;
    std::uint64_t from_frame = 0;  ///< the first frame whose READY it owes
    bool ready = false;
    std::string peer;              ///< routing id ("name#process") of the process that is this node
  };
  MasterOptions opt;
  zmq::context_t ctx{1};
  zmq::socket_t pub{ctx, zmq::socket_type::pub};
  zmq::socket_t router{ctx, zmq::socket_type::router};
  std::map<std::string, Member, std::less<>> members;  // every configured node, by name
  std::uint64_t frame = 0;
  bool published = false;
  Timestamp published_at = 0;
  std::string out, reply;
  zmq::message_t id_msg, body_msg;
  BarrierReport report;
  MasterStats stats;
  std::vector<std::string> events;

  explicit Impl(MasterOptions o) : opt(std::move(o)) {
    for (const auto& n : opt.config.nodes) members[n.name] = {};
    detail::common_options(pub, false);
    detail::common_options(router, true);
    pub.set(zmq::sockopt::sndhwm, 8);  // a stopped node's backlog: a few frames, then dropped
    pub.set(zmq::sockopt::tcp_keepalive, 1);
    const std::string sb = opt.config.state_bind.value_or(opt.config.state);
    const std::string cb = opt.config.control_bind.value_or(opt.config.control);
    for (auto [s, e] : {std::pair{&pub, sb}, std::pair{&router, cb}}) {
      try {
        s->bind(e);
      } catch (const zmq::error_t& err) {
        throw Error("cluster", "bind", fmt::format("cluster master: cannot bind {}: {}", e, err.what()));
      }
    }
  }

  void send_to(std::string_view node, MessageType type, std::string_view text = {}) {
    Header h{type, opt.config_hash, frame, now(), 0};
    encode_message(h, std::as_bytes(std::span(text.data(), text.size())), reply);
    router.send(zmq::buffer(node.data(), node.size()), zmq::send_flags::sndmore | zmq::send_flags::dontwait);
    router.send(zmq::buffer(reply), zmq::send_flags::dontwait);
  }

  /// One control message from a node, if any is waiting.
  bool handle_one() {
    if (!detail::try_recv(router, id_msg)) return false;
    if (!id_msg.more()) return true;  // a malformed multipart: no body
    if (!detail::try_recv(router, body_msg)) return true;
    while (body_msg.more()) {  // extra parts: not ours
      zmq::message_t extra;
      if (!detail::try_recv(router, extra)) break;
      stats.defects.count(Defect::oversized);
    }
    // The routing id is "name#process": the node's name, and which process is it.
    const std::string_view peer(static_cast<const char*>(id_msg.data()), id_msg.size());
    const std::string_view name = peer.substr(0, peer.find('#'));
    Header h;
    std::string_view payload;
    const Defect d = decode_message(body_msg.to_string_view(), opt.config_hash, h, payload);
    if (d != Defect::none) {
      stats.defects.count(d);
      return true;
    }
    auto it = members.find(name);
    switch (h.type) {
      case MessageType::hello: {
        std::string why;
        if (h.config_hash != opt.config_hash)
          why = fmt::format("node \"{}\" refused: its installation file (hash {:016x}) is not the master's ({:016x}): "
                            "start every process with the same file",
                            name, h.config_hash, opt.config_hash);
        else if (it == members.end())
          why = fmt::format("node \"{}\" refused: not a node of the installation file's [[cluster.nodes]]", name);
        // Another process under a name whose process is in the barrier now: the name is taken
        // (a node killed and restarted has left the barrier by the time it is back).
        if (why.empty() && it->second.active && it->second.peer != peer)
          why = fmt::format("node \"{}\" refused: named twice: another process is node \"{}\" and is in the barrier",
                            name, name);
        if (!why.empty()) {
          ++stats.refusals;
          events.push_back(why);
          send_to(peer, MessageType::refused, why);
          return true;
        }
        Member& m = it->second;
        m.peer = std::string(peer);
        if (!m.active) {
          ++stats.joins;
          events.push_back(fmt::format("node \"{}\" joined the barrier at frame {}", name, published ? frame + 1 : frame));
        }
        m.active = true;
        m.misses = 0;
        m.ready = false;
        m.from_frame = published ? frame + 1 : frame;  // not the frame being gathered: it has not its STATE
        send_to(peer, MessageType::welcome);
        return true;
      }
      case MessageType::ready:
        if (it == members.end() || it->second.peer != peer) return true;  // not the node's process
        if (!it->second.active) {
          send_to(peer, MessageType::left);  // say HELLO to come back
          return true;
        }
        if (published && h.frame == frame) it->second.ready = true;
        return true;
      case MessageType::bye:
        if (it != members.end() && it->second.active && it->second.peer == peer) {
          it->second.active = false;
          ++stats.leaves;
          events.push_back(fmt::format("node \"{}\" said goodbye", name));
        }
        return true;
      default:
        stats.defects.count(Defect::bad_type);  // a master's message sent to the master
        return true;
    }
  }

  void handle_waiting() {
    while (handle_one()) {
    }
  }

  bool all_ready(int& owed, int& in) const {
    owed = 0;
    in = 0;
    for (const auto& [name, m] : members)
      if (m.active && m.from_frame <= frame) {
        ++owed;
        if (m.ready) ++in;
      }
    return in == owed;
  }
};

Master::Master(MasterOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}
Master::~Master() = default;

void Master::publish(std::uint64_t frame, double master_time_s, std::span<const std::byte> state) {
  auto& m = *impl_;
  m.handle_waiting();
  m.frame = frame;
  for (auto& [name, mem] : m.members) mem.ready = false;
  encode_message({MessageType::state, m.opt.config_hash, frame, master_time_s, 0}, state, m.out);
  m.published_at = now();
  m.pub.send(zmq::buffer(m.out), zmq::send_flags::dontwait);
  m.published = true;
  ++m.stats.frames;
  m.stats.state_bytes_last = m.out.size();
  m.stats.state_bytes_max = std::max<std::uint64_t>(m.stats.state_bytes_max, m.out.size());
  m.stats.state_bytes_total += m.out.size();
}

const BarrierReport& Master::release() {
  auto& m = *impl_;
  auto& r = m.report;
  r.frame = m.frame;
  r.left.clear();
  r.deadline_hit = false;
  const Timestamp deadline = m.published_at + m.opt.deadline_s;
  int owed = 0, in = 0;
  m.handle_waiting();
  while (!m.all_ready(owed, in)) {
    const double left = deadline - now();
    if (left <= 0) {
      r.deadline_hit = true;
      break;
    }
    zmq::pollitem_t item{m.router.handle(), 0, ZMQ_POLLIN, 0};
    detail::poll(&item, 1, detail::poll_ms(std::min(left, 0.002)));
    m.handle_waiting();
  }
  r.members = owed;
  r.ready = in;
  if (r.deadline_hit) {
    ++m.stats.deadlines_hit;
    for (auto& [name, mem] : m.members) {
      if (!mem.active || mem.from_frame > m.frame) continue;
      if (mem.ready) {
        mem.misses = 0;
        continue;
      }
      if (++mem.misses >= m.opt.config.max_misses) {
        mem.active = false;
        ++m.stats.leaves;
        r.left.push_back(name);
        m.events.push_back(fmt::format("node \"{}\" left the barrier at frame {}: {} deadlines missed in a row", name,
                                       m.frame, mem.misses));
        m.send_to(mem.peer, MessageType::left);
      }
    }
  } else {
    for (auto& [name, mem] : m.members)
      if (mem.ready) mem.misses = 0;
  }
  encode_message({MessageType::go, m.opt.config_hash, m.frame, now(), 0}, {}, m.out);
  m.pub.send(zmq::buffer(m.out), zmq::send_flags::dontwait);
  r.gather_s = now() - m.published_at;
  m.published = false;
  return r;
}

std::vector<std::string> Master::members() const {
  std::vector<std::string> out;
  for (const auto& [name, m] : impl_->members)
    if (m.active) out.push_back(name);
  return out;
}

const MasterStats& Master::stats() const { return impl_->stats; }

std::vector<std::string> Master::take_events() { return std::exchange(impl_->events, {}); }

}  // namespace kumite::cluster
