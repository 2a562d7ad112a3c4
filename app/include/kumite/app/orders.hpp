#pragma once
// Supervisor orders from a script: a CSV file with rows `time_s,order` (time in seconds from
// the start of the run; orders as kumite::parse_order reads them: punch_left, punch_right,
// kick_left, kick_right, character N, pause, resume, recentre). Blank lines and lines starting
// with '#' are skipped; a first row `time_s,order` is a header.
#include <cstddef>
#include <filesystem>
#include <string_view>
#include <vector>

#include "kumite/common/wire.hpp"

namespace kumite::app {

/// Parses script text; `file` names it in errors ("file:line: time_s: ..."). Rows must be in
/// time order. Throws kumite::Error("orders", ...).
std::vector<Order> parse_orders_script(std::string_view text, std::string_view file);
std::vector<Order> load_orders_script(const std::filesystem::path& file);

/// Hands out scripted orders as their time comes (times relative to `start`).
class OrderScript {
 public:
  OrderScript() = default;
  OrderScript(std::vector<Order> orders, Timestamp start) : orders_(std::move(orders)), start_(start) {}
  /// Appends the orders due by `now` to `out` (each with time = start + time_s).
  void due(Timestamp now, std::vector<Order>& out);
  /// Counts the script's times from `start` (s).
  void restart(Timestamp start) { start_ = start; next_ = 0; }
  std::size_t remaining() const { return orders_.size() - next_; }

 private:
  std::vector<Order> orders_;
  Timestamp start_ = 0;
  std::size_t next_ = 0;
};

}  // namespace kumite::app
