// Fuzzes the DTrack ASCII parser (a datagram from the network): never a crash; what it keeps is
// within its limits and finite, converts to Kumite's room and formats back to a packet that
// parses without a problem.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "kumite/tracking/interop.hpp"

using namespace kumite::tracking;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static DtrackFrame f, g;
  static RoomFrame room;
  parse_dtrack(std::string_view(reinterpret_cast<const char*>(data), size), f);
  if (f.problem_count < static_cast<int>(f.problems.size()) || f.problems.size() > 16) std::abort();
  for (const auto& b : f.bodies) {
    if (b.id < 0 || b.id >= kDtrackMaxBodies || !(b.quality >= -1 && b.quality <= 1)) std::abort();
    for (double v : b.position_m)
      if (!std::isfinite(v)) std::abort();
    for (double v : b.rotation)
      if (!std::isfinite(v)) std::abort();
  }
  DtrackInput in;
  in.role_body = {0, 1, 2, -1, -1};
  to_room_frame(f, in, room);
  if (room.body_count > kRoomFrameBodies) std::abort();
  // Formatting rounds the matrix to 6 decimals: a kept rotation already near the parser's 1e-3
  // orthonormality limit may cross it; the round trip is checked for the others.
  bool clean = true;
  for (const auto& b : f.bodies) {
    const auto& r = b.rotation;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double d = 0;
        for (int k = 0; k < 3; ++k) d += r[static_cast<std::size_t>(i * 3 + k)] * r[static_cast<std::size_t>(j * 3 + k)];
        if (std::abs(d - (i == j ? 1.0 : 0.0)) > 1e-4) clean = false;
      }
  }
  if (f.has_frame && clean) {
    parse_dtrack(format_dtrack(f), g);
    if (!g.ok()) std::abort();
    std::size_t tracked = 0;
    for (const auto& b : f.bodies) tracked += b.tracked() ? 1 : 0;
    if (g.bodies.size() != tracked || g.frame != f.frame) std::abort();
  }
  return 0;
}
