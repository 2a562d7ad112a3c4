#pragma once
// Checked reading of one line of a JSON log (session.jsonl, manifest.json, frames.jsonl):
// every value missing, of the wrong type, not finite or out of range is a kumite::Error
// "file:line: key: message" with the reader's component and code. Internal to app_core
// (session replay and kumite export).
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "kumite/common/error.hpp"

namespace kumite::app {

struct JsonLineReader {
  std::string component, code;  ///< of the errors ("replay" "session", "export" "log")
  std::string file;
  int line = 0;

  [[noreturn]] void fail(std::string_view key, std::string_view message) const {
    throw file_error(component, code, file, line, key, message);
  }
  const nlohmann::json& at(const nlohmann::json& j, std::string_view key, std::string_view path) const {
    if (!j.is_object() || !j.contains(key)) fail(path, "missing");
    return j.at(std::string(key));
  }
  double num(const nlohmann::json& j, std::string_view path) const {
    if (!j.is_number()) fail(path, "not a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(path, "must be a finite number");
    return v;
  }
  /// A whole number in [lo, hi] (checked before any cast).
  double whole(const nlohmann::json& j, std::string_view path, double lo, double hi) const {
    const double v = num(j, path);
    if (v != std::floor(v) || v < lo || v > hi) fail(path, fmt::format("expected a whole number in [{:g}, {:g}]", lo, hi));
    return v;
  }
  template <std::size_t N>
  std::array<double, N> nums(const nlohmann::json& j, std::string_view path) const {
    if (!j.is_array() || j.size() != N) fail(path, fmt::format("expected {} numbers", N));
    std::array<double, N> out{};
    for (std::size_t k = 0; k < N; ++k) out[k] = num(j[k], path);
    return out;
  }
};

}  // namespace kumite::app
