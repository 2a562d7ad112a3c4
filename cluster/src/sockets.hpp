#pragma once
// The ZeroMQ side both ends share: socket options and sending one message without blocking.
#include <chrono>
#include <string>

#include <zmq.hpp>

#include "kumite/common/time.hpp"

namespace kumite::cluster::detail {

/// Every socket: closes at once (no linger), dead peers seen within 300 ms by heartbeats.
inline void common_options(zmq::socket_t& s) {
  s.set(zmq::sockopt::linger, 0);
  s.set(zmq::sockopt::heartbeat_ivl, 100);
  s.set(zmq::sockopt::heartbeat_timeout, 300);
  s.set(zmq::sockopt::heartbeat_ttl, 300);
  s.set(zmq::sockopt::reconnect_ivl, 50);
  s.set(zmq::sockopt::reconnect_ivl_max, 250);
}

/// ms to wait in zmq::poll for `seconds` (rounded up, at least 0).
inline std::chrono::milliseconds poll_ms(double seconds) {
  if (!(seconds > 0)) return std::chrono::milliseconds(0);
  return std::chrono::milliseconds(static_cast<long>(seconds * 1e3) + 1);
}

}  // namespace kumite::cluster::detail
