#pragma once
// One error type for the whole project (as SGCT does): a component ("bvh", "config",
// "calibration", ...), a short stable code ("parse", "missing_key", ...) and a one-line
// message that names the file, line or field. Tools print what() and exit non-zero.
#include <stdexcept>
#include <string>
#include <string_view>

#include <fmt/format.h>

namespace kumite {

class Error : public std::runtime_error {
 public:
  Error(std::string component, std::string code, const std::string& message)
      : std::runtime_error(message), component_(std::move(component)), code_(std::move(code)) {}

  const std::string& component() const noexcept { return component_; }
  const std::string& code() const noexcept { return code_; }

 private:
  std::string component_;
  std::string code_;
};

/// "file:line: key: message" (line 0 = unknown line, key "" = whole file), the shape of every
/// config, annotation and data-file error.
std::string format_location(std::string_view file, int line, std::string_view key,
                            std::string_view message);

/// An Error for a problem in an input file, located as format_location() does.
Error file_error(std::string_view component, std::string_view code, std::string_view file,
                 int line, std::string_view key, std::string_view message);

}  // namespace kumite
