#pragma once
// The ZeroMQ side both ends share: socket options and sending one message without blocking.
#include <cerrno>
#include <chrono>
#include <string>

#include <zmq.hpp>

#include "kumite/common/time.hpp"

namespace kumite::cluster::detail {

/// Every socket: closes at once (no linger), reconnects within 50-250 ms. `heartbeats`: dead
/// peers seen within 300 ms (the control sockets only). The STATE/GO sockets have none: a
/// heartbeat timeout on a connection whose input is stalled by its high-water mark (a node busy
/// while the master publishes) trips libzmq 4.3.4's `_input_stopped` assertion on reconnect
/// (zeromq/libzmq#3937); a node sees a lost master by its STATEs stopping instead.
inline void common_options(zmq::socket_t& s, bool heartbeats) {
  s.set(zmq::sockopt::linger, 0);
  if (heartbeats) {
    s.set(zmq::sockopt::heartbeat_ivl, 100);
    s.set(zmq::sockopt::heartbeat_timeout, 300);
    s.set(zmq::sockopt::heartbeat_ttl, 300);
  }
  s.set(zmq::sockopt::reconnect_ivl, 50);
  s.set(zmq::sockopt::reconnect_ivl_max, 250);
}

/// ms to wait in zmq::poll for `seconds` (rounded up, at least 0).
inline std::chrono::milliseconds poll_ms(double seconds) {
  if (!(seconds > 0)) return std::chrono::milliseconds(0);
  return std::chrono::milliseconds(static_cast<long>(seconds * 1e3) + 1);
}

/// zmq::poll that takes a signal's interruption (SIGTERM ending a run) for a timeout.
inline void poll(zmq::pollitem_t* items, std::size_t n, std::chrono::milliseconds timeout) {
  try {
    zmq::poll(items, n, timeout);
  } catch (const zmq::error_t& e) {
    if (e.num() != EINTR) throw;
  }
}

/// A message if one is waiting (a signal's interruption: none).
inline bool try_recv(zmq::socket_t& s, zmq::message_t& m) {
  try {
    return s.recv(m, zmq::recv_flags::dontwait).has_value();
  } catch (const zmq::error_t& e) {
    if (e.num() != EINTR) throw;
    return false;
  }
}

}  // namespace kumite::cluster::detail
