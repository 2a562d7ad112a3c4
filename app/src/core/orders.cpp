#include "kumite/app/orders.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/common/text.hpp"

namespace kumite::app {

std::vector<Order> parse_orders_script(std::string_view text, std::string_view file) {
  text = without_utf8_bom(text);  // a spreadsheet's "CSV UTF-8": the mark before the header
  std::vector<Order> out;
  int line_no = 0;
  double last = -1e300;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    const std::string_view raw = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    ++line_no;
    const std::string_view line = trim_blanks(raw);
    if (line.empty() || line.front() == '#') continue;
    const auto comma = line.find(',');
    if (comma == std::string_view::npos)
      throw file_error("orders", "parse", file, line_no, "", "expected `time_s,order`");
    const std::string_view t = trim_blanks(line.substr(0, comma)), o = trim_blanks(line.substr(comma + 1));
    if (t == "time_s" && o == "order" && out.empty()) continue;  // header
    double time = 0;
    const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), time);
    if (ec == std::errc() && end == t.data() + t.size() && !std::isfinite(time))
      throw file_error("orders", "not_finite", file, line_no, "time_s",
                       fmt::format("must be a finite number (found \"{}\")", t));
    if (ec != std::errc() || end != t.data() + t.size() || time < 0)
      throw file_error("orders", "parse", file, line_no, "time_s",
                       fmt::format("\"{}\" is not a time in seconds >= 0", t));
    if (time < last)
      throw file_error("orders", "order", file, line_no, "time_s",
                       fmt::format("{} s comes before the previous row ({} s)", time, last));
    last = time;
    const auto order = parse_order(o, time);
    if (!order)
      throw file_error("orders", "parse", file, line_no, "order",
                       fmt::format("unknown order \"{}\" (punch_left, punch_right, kick_left, "
                                   "kick_right, character N, pause, resume, recentre)", o));
    out.push_back(*order);
  }
  return out;
}

std::vector<Order> load_orders_script(const std::filesystem::path& file) {
  std::error_code ec;
  if (std::filesystem::is_directory(file, ec))
    throw file_error("orders", "open", file.string(), 0, "", "is a folder, not a file: give the orders script (.csv)");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw file_error("orders", "open", file.string(), 0, "", "cannot open the orders script");
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_orders_script(ss.str(), file.string());
}

void OrderScript::due(Timestamp now, std::vector<Order>& out) {
  while (next_ < orders_.size() && start_ + orders_[next_].time <= now) {
    Order o = orders_[next_++];
    o.time += start_;
    out.push_back(o);
  }
}

}  // namespace kumite::app
