// The receivers' shared plumbing (thread, newest frame, counters, problem lines), DTrack ASCII
// over UDP in (DtrackReceiver) and out (DtrackSender).
#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <bitset>
#include <cerrno>
#include <cstring>
#include <mutex>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/tracking/interop.hpp"

namespace kumite::tracking {

// --- Receiver ------------------------------------------------------------------------------

namespace {
constexpr std::size_t kKeptLines = 100;
}

struct Receiver::Problems {
  std::mutex mutex;
  std::vector<std::string> lines;
  std::uint64_t left_out = 0;
};

Receiver::~Receiver() = default;

void Receiver::start() {
  if (running()) return;
  if (!problems_) problems_ = std::make_shared<Problems>();
  stopping_.store(false);
  open();
  thread_ = std::thread([this] { run(); });
}

void Receiver::stop() {
  stopping_.store(true);
  if (thread_.joinable()) {
    thread_.join();
    close();
  }
}

ReceiverCounters Receiver::counters() const {
  ReceiverCounters c;
  c.packets = packets_.load();
  c.frames = frames_.load();
  c.bad_packets = bad_packets_.load();
  c.oversized = oversized_.load();
  c.unconfigured_bodies = unconfigured_.load();
  c.frame_gaps = frame_gaps_.load();
  return c;
}

std::vector<std::string> Receiver::take_problems() {
  std::vector<std::string> out;
  if (!problems_) return out;
  std::lock_guard lock(problems_->mutex);
  out.swap(problems_->lines);
  if (problems_->left_out > 0) {
    out.push_back(fmt::format("... and {} more problem lines left out", problems_->left_out));
    problems_->left_out = 0;
  }
  return out;
}

void Receiver::publish(RoomFrame& frame) {
  frame.sequence = ++sequence_;
  frame.published_at = now();
  latest_.publish(frame);
  frames_.fetch_add(1, std::memory_order_relaxed);
  if (on_publish_) on_publish_(frame);
}

std::string Receiver::last_sender() const {
  const std::uint64_t v = last_sender_.load(std::memory_order_relaxed);
  if (!(v >> 48)) return {};
  in_addr a{};
  a.s_addr = static_cast<std::uint32_t>(v >> 16);
  char host[INET_ADDRSTRLEN] = "?";
  inet_ntop(AF_INET, &a, host, sizeof host);
  return fmt::format("{}:{}", host, static_cast<unsigned>(v & 0xffff));
}

void Receiver::problem(std::string line) {
  std::lock_guard lock(problems_->mutex);
  if (problems_->lines.size() < kKeptLines) problems_->lines.push_back(std::move(line));
  else ++problems_->left_out;
}

void Receiver::note_frame_number(std::uint64_t frame) {
  if (have_frame_number_ && frame > last_frame_number_ + 1)
    frame_gaps_.fetch_add(frame - last_frame_number_ - 1, std::memory_order_relaxed);
  have_frame_number_ = true;
  last_frame_number_ = frame;
}

// --- DtrackReceiver ------------------------------------------------------------------------

DtrackReceiver::DtrackReceiver(DtrackInput input) : DtrackReceiver(std::move(input), Options{}) {}

DtrackReceiver::DtrackReceiver(DtrackInput input, Options options)
    : input_(std::move(input)), options_(std::move(options)) {}

DtrackReceiver::~DtrackReceiver() { stop(); }

namespace {
[[noreturn]] void socket_error(const std::string& what) {
  throw Error("interop", "socket", fmt::format("{}: {}", what, std::strerror(errno)));
}
}  // namespace

void DtrackReceiver::open() {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) socket_error("dtrack: socket");
  const int one = 1;
  if (!input_.multicast_group.empty()) setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(input_.port));
  if (inet_pton(AF_INET, input_.bind_address.c_str(), &a.sin_addr) != 1) {
    close();
    throw Error("interop", "socket", fmt::format("dtrack: '{}' is not an IPv4 address", input_.bind_address));
  }
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    const std::string what = fmt::format("dtrack: cannot listen on udp {}:{}", input_.bind_address, input_.port);
    const int e = errno;
    close();
    errno = e;
    socket_error(what);
  }
  if (!input_.multicast_group.empty()) {
    ip_mreq m{};
    inet_pton(AF_INET, input_.multicast_group.c_str(), &m.imr_multiaddr);
    m.imr_interface.s_addr = htonl(INADDR_ANY);
    if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m) != 0) {
      const int e = errno;
      close();
      errno = e;
      socket_error(fmt::format("dtrack: cannot join multicast group {}", input_.multicast_group));
    }
  }
  sockaddr_in bound{};
  socklen_t len = sizeof bound;
  getsockname(fd_, reinterpret_cast<sockaddr*>(&bound), &len);
  bound_port_.store(ntohs(bound.sin_port));
}

void DtrackReceiver::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void DtrackReceiver::run() {
  std::vector<char> buffer(options_.buffer_bytes + 1);
  DtrackFrame frame;
  frame.bodies.reserve(kRoomFrameBodies);
  frame.problems.reserve(16);
  RoomFrame room;
  std::bitset<kDtrackMaxBodies> said_unconfigured;
  const auto source = [](const sockaddr_in& from) {
    char host[INET_ADDRSTRLEN] = "?";
    inet_ntop(AF_INET, &from.sin_addr, host, sizeof host);
    return fmt::format("dtrack {}:{}", host, ntohs(from.sin_port));
  };
  while (!stopping_.load(std::memory_order_relaxed)) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    // Every datagram queued, oldest first (each is counted and checked; each good one published).
    for (;;) {
      sockaddr_in from{};
      socklen_t from_len = sizeof from;
      const ssize_t n = ::recvfrom(fd_, buffer.data(), buffer.size(), MSG_DONTWAIT | MSG_TRUNC,
                                   reinterpret_cast<sockaddr*>(&from), &from_len);
      if (n < 0) break;  // EAGAIN: none left (or an error the next poll() reports again)
      const Timestamp received = now();
      packets_.fetch_add(1, std::memory_order_relaxed);
      note_sender(from.sin_addr.s_addr, ntohs(from.sin_port));
      if (static_cast<std::size_t>(n) > options_.buffer_bytes) {
        oversized_.fetch_add(1, std::memory_order_relaxed);
        bad_packets_.fetch_add(1, std::memory_order_relaxed);
        problem(fmt::format("{}: packet: {} bytes, more than the receive buffer ({}): oversized (ignored)",
                            source(from), n, options_.buffer_bytes));
        continue;
      }
      parse_dtrack(std::string_view(buffer.data(), static_cast<std::size_t>(n)), frame);
      if (!frame.ok()) {
        bad_packets_.fetch_add(1, std::memory_order_relaxed);
        const std::string where = source(from);
        for (const auto& line : frame.problems) problem(fmt::format("{}: {}", where, line));
        if (frame.problem_count > static_cast<int>(frame.problems.size()))
          problem(fmt::format("{}: packet: {} more problems in it", where,
                              frame.problem_count - static_cast<int>(frame.problems.size())));
      }
      if (!frame.has_frame) {
        if (options_.on_packet) options_.on_packet(frame, room);
        continue;  // nothing usable: not published
      }
      room.received_at = received;
      const int unconfigured = to_room_frame(frame, input_, room);
      if (unconfigured > 0) {
        unconfigured_.fetch_add(static_cast<std::uint64_t>(unconfigured), std::memory_order_relaxed);
        for (const auto& b : frame.bodies) {
          const auto id = static_cast<std::size_t>(b.id);
          if (input_.role_of(b.id) >= 0 || said_unconfigured.test(id)) continue;
          said_unconfigured.set(id);
          problem(fmt::format("{}: packet: 6d: body {} is not configured in [dtrack.bodies] (ignored; said once)",
                              source(from), b.id));
        }
      }
      note_frame_number(frame.frame);
      publish(room);
      if (options_.on_packet) options_.on_packet(frame, room);
    }
  }
}

// --- DtrackSender --------------------------------------------------------------------------

DtrackSender::DtrackSender(const std::string& host, int port) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_DGRAM;
  addrinfo* res = nullptr;
  const std::string service = std::to_string(port);
  if (port < 1 || port > 65535 || getaddrinfo(host.c_str(), service.c_str(), &hints, &res) != 0 || !res)
    throw Error("interop", "socket", fmt::format("dtrack: cannot send to '{}:{}': no such IPv4 host or port", host, port));
  static_assert(sizeof(sockaddr_in) <= sizeof(addr_));
  std::memcpy(addr_.data(), res->ai_addr, sizeof(sockaddr_in));
  freeaddrinfo(res);
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) socket_error("dtrack: socket");
}

DtrackSender::~DtrackSender() {
  if (fd_ >= 0) ::close(fd_);
}

bool DtrackSender::send(const DtrackFrame& frame) {
  format_dtrack(frame, buffer_);
  return send_raw(buffer_);
}

bool DtrackSender::send_raw(std::string_view bytes) {
  sockaddr_in to{};
  std::memcpy(&to, addr_.data(), sizeof to);
  const ssize_t n = ::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  if (n == static_cast<ssize_t>(bytes.size())) return true;
  error_ = n < 0 ? std::strerror(errno) : "sent only part of the packet";
  return false;
}

}  // namespace kumite::tracking
