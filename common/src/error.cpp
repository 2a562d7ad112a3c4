#include "kumite/common/error.hpp"

namespace kumite {

std::string format_location(std::string_view file, int line, std::string_view key,
                            std::string_view message) {
  std::string out(file);
  if (line > 0) out += fmt::format(":{}", line);
  out += ": ";
  if (!key.empty()) out += fmt::format("{}: ", key);
  out += message;
  return out;
}

Error file_error(std::string_view component, std::string_view code, std::string_view file,
                 int line, std::string_view key, std::string_view message) {
  return Error(std::string(component), std::string(code),
               format_location(file, line, key, message));
}

}  // namespace kumite
