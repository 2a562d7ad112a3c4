#pragma once
// The project's one strict TOML reader (issue 13): every file people edit (installation,
// tracking, board, motions, characters, dialects) is read through TomlTable, so every
// mistake is reported the same way, as one line "file:line: key: message" (kumite::Error,
// component as given, a stable code), and no reader can forget a check:
//
//   unknown_key  a key the table does not have ("unknown key (allowed here: a, b)")
//   missing_key  a required key is absent ("is required")
//   type         the value has the wrong type ("must be a number", "must be an integer", ...)
//   not_finite   nan or inf, which toml++ reads as numbers and no key of the project means
//   range        outside the key's range ("must be in [0, 100] ms, found 120")
//   empty        an empty string where text or a path is needed
//   parse / io   the file itself (TOML syntax, cannot open)
//
// Include this only from a library's .cpp (it brings toml++ with it); public headers stay free
// of TOML.
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

namespace kumite {

/// Parses TOML text; a syntax error throws Error(component, "parse") at its line.
toml::table parse_toml(std::string_view text, std::string_view file, std::string_view component);
/// Reads a whole file as text; Error(component, "io") naming it when it cannot be opened, or
/// when it is a folder.
std::string read_text_file(const std::filesystem::path& path, std::string_view component);

/// A closed range for a number read from a file (both ends allowed) and its unit for messages.
struct TomlRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  std::string_view unit;  ///< "m", "s", "ms", ... ("" none): "must be in [0, 100] ms, found 120"
  /// [min, inf): "must be >= 0 m, found -1".
  static TomlRange at_least(double min, std::string_view unit = {}) {
    return {min, std::numeric_limits<double>::infinity(), unit};
  }
  /// Any finite number, in `unit`.
  static TomlRange any(std::string_view unit) {
    return {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), unit};
  }
};

/// Strict access to one table of a parsed document. Keys are reported by their dotted path
/// from the document's root ("walls[1].lower_left", "fighter.behaviour.walk_speed_mps").
class TomlTable {
 public:
  TomlTable(const toml::table& table, std::string_view component, std::string_view file,
            std::string path = {});

  const toml::table& raw() const { return t_; }
  const std::string& path() const { return path_; }
  std::string_view file() const { return file_; }
  std::string_view component() const { return component_; }
  /// The dotted path of `key` in this table.
  std::string key_path(std::string_view key) const;
  /// Line of the table's header (or its first key), and of `key` (the table's when absent).
  int line() const;
  int line(std::string_view key) const;

  /// Error at `key` (its line, or the table's when it is absent).
  [[noreturn]] void fail(std::string_view code, std::string_view key, std::string_view message) const;
  /// Error at a node inside this table (an array element), named `key`.
  [[noreturn]] void fail_at(const toml::node& node, std::string_view code, std::string_view key,
                            std::string_view message) const;

  /// Every key must be one of `allowed`: "unknown key (allowed here: a, b, c)".
  void only(std::initializer_list<std::string_view> allowed) const;
  void only(const std::vector<std::string_view>& allowed) const;
  bool has(std::string_view key) const { return t_.contains(key); }

  /// Numbers: an integer or a float, finite, within `range`. opt_*: nullopt when absent.
  std::optional<double> opt_number(std::string_view key, const TomlRange& range = {}) const;
  double number(std::string_view key, const TomlRange& range = {}) const;
  /// Sets `out` when the key is present; returns whether it was.
  bool read(std::string_view key, double& out, const TomlRange& range = {}) const;

  std::optional<std::int64_t> opt_integer(
      std::string_view key, std::int64_t min = std::numeric_limits<std::int64_t>::min(),
      std::int64_t max = std::numeric_limits<std::int64_t>::max()) const;
  std::int64_t integer(std::string_view key, std::int64_t min = std::numeric_limits<std::int64_t>::min(),
                       std::int64_t max = std::numeric_limits<std::int64_t>::max()) const;
  bool read(std::string_view key, int& out, int min = std::numeric_limits<int>::min(),
            int max = std::numeric_limits<int>::max()) const;

  std::optional<bool> opt_boolean(std::string_view key) const;
  bool read(std::string_view key, bool& out) const;

  /// Strings: `allow_empty` false refuses "" ("must not be empty", code empty).
  std::optional<std::string> opt_string(std::string_view key, bool allow_empty = true) const;
  std::string string(std::string_view key, bool allow_empty = true) const;
  bool read(std::string_view key, std::string& out, bool allow_empty = true) const;
  /// A path as written (never empty).
  bool read(std::string_view key, std::filesystem::path& out) const;

  /// A fixed-size array of numbers, each finite and within `range`.
  template <std::size_t N>
  std::optional<std::array<double, N>> opt_numbers(std::string_view key, const TomlRange& range = {}) const {
    std::array<double, N> out{};
    if (!read_numbers(key, out.data(), N, range)) return std::nullopt;
    return out;
  }
  template <std::size_t N>
  bool read(std::string_view key, std::array<double, N>& out, const TomlRange& range = {}) const {
    return read_numbers(key, out.data(), N, range);
  }
  /// A fixed-size array of integers within [min, max].
  template <std::size_t N>
  bool read(std::string_view key, std::array<int, N>& out, int min = std::numeric_limits<int>::min(),
            int max = std::numeric_limits<int>::max()) const {
    return read_integers(key, out.data(), N, min, max);
  }

  /// A sub-table ([a.b] or b = { ... }): nullopt when absent, "must be a table" when not one.
  std::optional<TomlTable> opt_table(std::string_view key) const;
  TomlTable table(std::string_view key) const;
  /// An array (nullptr when absent; "must be an array" when not one).
  const toml::array* opt_array(std::string_view key) const;
  /// An array of tables ([[key]]), each named "key[i]": empty when absent.
  std::vector<TomlTable> tables(std::string_view key) const;

 private:
  bool read_numbers(std::string_view key, double* out, std::size_t n, const TomlRange& range) const;
  bool read_integers(std::string_view key, int* out, std::size_t n, int min, int max) const;
  double checked_number(const toml::node& n, std::string_view key, const TomlRange& range) const;

  const toml::table& t_;
  std::string component_;
  std::string file_;
  std::string path_;
};

/// The line of every key of a document by its dotted path ("walls[1].lower_left",
/// "stereo.mode"; arrays of tables as "walls[1]"): for messages of checks made after reading.
std::map<std::string, int> toml_key_lines(const toml::table& root);

}  // namespace kumite
