#include "kumite/common/toml_reader.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "kumite/common/error.hpp"

namespace kumite {

toml::table parse_toml(std::string_view text, std::string_view file, std::string_view component) {
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    throw file_error(component, "parse", file, static_cast<int>(e.source().begin.line), "",
                     std::string(e.description()));
  }
}

std::string read_text_file(const std::filesystem::path& path, std::string_view component) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw file_error(component, "io", path.string(), 0, "", "is a folder, not a file");
  }
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
    throw file_error(component, "io", path.string(), 0, "", "is not a regular file");  // a device or FIFO: no end
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error(component, "io", path.string(), 0, "", "cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw file_error(component, "io", path.string(), 0, "", "cannot read file");
  return ss.str();
}

TomlTable::TomlTable(const toml::table& table, std::string_view component, std::string_view file,
                     std::string path)
    : t_(table), component_(component), file_(file), path_(std::move(path)) {}

std::string TomlTable::key_path(std::string_view key) const {
  if (path_.empty()) return std::string(key);
  if (key.empty()) return path_;
  return path_ + "." + std::string(key);
}

int TomlTable::line() const { return static_cast<int>(t_.source().begin.line); }

int TomlTable::line(std::string_view key) const {
  const toml::node* n = t_.get(key);
  return static_cast<int>((n ? n->source() : t_.source()).begin.line);
}

void TomlTable::fail(std::string_view code, std::string_view key, std::string_view message) const {
  throw file_error(component_, code, file_, line(key), key_path(key), message);
}

void TomlTable::fail_at(const toml::node& node, std::string_view code, std::string_view key,
                        std::string_view message) const {
  throw file_error(component_, code, file_, static_cast<int>(node.source().begin.line), key_path(key),
                   message);
}

void TomlTable::only(std::initializer_list<std::string_view> allowed) const {
  only(std::vector<std::string_view>(allowed));
}

void TomlTable::only(const std::vector<std::string_view>& allowed) const {
  for (const auto& [k, v] : t_) {
    if (std::find(allowed.begin(), allowed.end(), k.str()) != allowed.end()) continue;
    std::string list;
    for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    fail_at(v, "unknown_key", k.str(), fmt::format("unknown key (allowed here: {})", list));
  }
}

namespace {
std::string range_text(const TomlRange& r) {
  const std::string unit = r.unit.empty() ? "" : " " + std::string(r.unit);
  if (std::isinf(r.max)) return fmt::format("must be >= {}{}", r.min, unit);
  if (std::isinf(r.min)) return fmt::format("must be <= {}{}", r.max, unit);
  return fmt::format("must be in [{}, {}]{}", r.min, r.max, unit);
}
}  // namespace

double TomlTable::checked_number(const toml::node& n, std::string_view key, const TomlRange& range) const {
  double v = 0;
  if (auto i = n.value_exact<std::int64_t>()) {
    v = static_cast<double>(*i);
  } else if (auto d = n.value_exact<double>()) {
    v = *d;
  } else {
    fail_at(n, "type", key, "must be a number");
  }
  if (!std::isfinite(v)) fail_at(n, "not_finite", key, "must be a finite number");
  if (v < range.min || v > range.max) {
    fail_at(n, "range", key, fmt::format("{}, found {}", range_text(range), v));
  }
  return v;
}

std::optional<double> TomlTable::opt_number(std::string_view key, const TomlRange& range) const {
  const toml::node* n = t_.get(key);
  if (!n) return std::nullopt;
  return checked_number(*n, key, range);
}

double TomlTable::number(std::string_view key, const TomlRange& range) const {
  auto v = opt_number(key, range);
  if (!v) fail("missing_key", key, "is required");
  return *v;
}

bool TomlTable::read(std::string_view key, double& out, const TomlRange& range) const {
  auto v = opt_number(key, range);
  if (v) out = *v;
  return v.has_value();
}

std::optional<std::int64_t> TomlTable::opt_integer(std::string_view key, std::int64_t min,
                                                   std::int64_t max) const {
  const toml::node* n = t_.get(key);
  if (!n) return std::nullopt;
  auto i = n->value_exact<std::int64_t>();
  if (!i) fail_at(*n, "type", key, "must be an integer");
  if (*i < min || *i > max) {
    const bool no_max = max == std::numeric_limits<std::int64_t>::max();
    const bool no_min = min == std::numeric_limits<std::int64_t>::min();
    const std::string what = no_max ? fmt::format("must be >= {}", min)
                             : no_min ? fmt::format("must be <= {}", max)
                                      : fmt::format("must be in [{}, {}]", min, max);
    fail_at(*n, "range", key, fmt::format("{}, found {}", what, *i));
  }
  return *i;
}

std::int64_t TomlTable::integer(std::string_view key, std::int64_t min, std::int64_t max) const {
  auto v = opt_integer(key, min, max);
  if (!v) fail("missing_key", key, "is required");
  return *v;
}

bool TomlTable::read(std::string_view key, int& out, int min, int max) const {
  auto v = opt_integer(key, min, max);
  if (v) out = static_cast<int>(*v);
  return v.has_value();
}

std::optional<bool> TomlTable::opt_boolean(std::string_view key) const {
  const toml::node* n = t_.get(key);
  if (!n) return std::nullopt;
  if (!n->is_boolean()) fail_at(*n, "type", key, "must be true or false");
  return n->as_boolean()->get();
}

bool TomlTable::read(std::string_view key, bool& out) const {
  auto v = opt_boolean(key);
  if (v) out = *v;
  return v.has_value();
}

std::optional<std::string> TomlTable::opt_string(std::string_view key, bool allow_empty) const {
  const toml::node* n = t_.get(key);
  if (!n) return std::nullopt;
  if (!n->is_string()) fail_at(*n, "type", key, "must be a string");
  std::string s = n->as_string()->get();
  if (!allow_empty && s.empty()) fail_at(*n, "empty", key, "must not be empty");
  return s;
}

std::string TomlTable::string(std::string_view key, bool allow_empty) const {
  auto v = opt_string(key, allow_empty);
  if (!v) fail("missing_key", key, "is required");
  return *v;
}

bool TomlTable::read(std::string_view key, std::string& out, bool allow_empty) const {
  auto v = opt_string(key, allow_empty);
  if (v) out = std::move(*v);
  return v.has_value();
}

bool TomlTable::read(std::string_view key, std::filesystem::path& out) const {
  auto v = opt_string(key, false);
  if (v) out = *v;
  return v.has_value();
}

bool TomlTable::read_numbers(std::string_view key, double* out, std::size_t n, const TomlRange& range) const {
  const toml::node* node = t_.get(key);
  if (!node) return false;
  const toml::array* a = node->as_array();
  if (!a || a->size() != n) fail_at(*node, "type", key, fmt::format("must be an array of {} numbers", n));
  for (std::size_t i = 0; i < n; ++i) out[i] = checked_number((*a)[i], key, range);
  return true;
}

bool TomlTable::read_integers(std::string_view key, int* out, std::size_t n, int min, int max) const {
  const toml::node* node = t_.get(key);
  if (!node) return false;
  const toml::array* a = node->as_array();
  if (!a || a->size() != n) fail_at(*node, "type", key, fmt::format("must be an array of {} integers", n));
  for (std::size_t i = 0; i < n; ++i) {
    const toml::node& e = (*a)[i];
    auto v = e.value_exact<std::int64_t>();
    if (!v) fail_at(e, "type", key, fmt::format("must be an array of {} integers", n));
    if (*v < min || *v > max) fail_at(e, "range", key, fmt::format("must be in [{}, {}], found {}", min, max, *v));
    out[i] = static_cast<int>(*v);
  }
  return true;
}

std::optional<TomlTable> TomlTable::opt_table(std::string_view key) const {
  const toml::node* n = t_.get(key);
  if (!n) return std::nullopt;
  if (!n->is_table()) fail_at(*n, "type", key, "must be a table");
  return TomlTable(*n->as_table(), component_, file_, key_path(key));
}

TomlTable TomlTable::table(std::string_view key) const {
  auto t = opt_table(key);
  if (!t) fail("missing_key", key, "is required (a table)");
  return *t;
}

const toml::array* TomlTable::opt_array(std::string_view key) const {
  const toml::node* n = t_.get(key);
  if (!n) return nullptr;
  if (!n->is_array()) fail_at(*n, "type", key, "must be an array");
  return n->as_array();
}

std::vector<TomlTable> TomlTable::tables(std::string_view key) const {
  std::vector<TomlTable> out;
  const toml::array* a = opt_array(key);
  if (!a) return out;
  for (std::size_t i = 0; i < a->size(); ++i) {
    const toml::node& n = (*a)[i];
    const std::string name = fmt::format("{}[{}]", key, i);
    if (!n.is_table()) fail_at(n, "type", name, fmt::format("must be a table ([[{}]])", key_path(key)));
    out.emplace_back(*n.as_table(), component_, file_, key_path(name));
  }
  return out;
}

namespace {
void collect_lines(const toml::node& n, const std::string& path, std::map<std::string, int>& out) {
  if (!path.empty()) out.emplace(path, static_cast<int>(n.source().begin.line));
  if (const toml::table* t = n.as_table()) {
    for (const auto& [k, v] : *t) collect_lines(v, path.empty() ? std::string(k.str()) : path + "." + std::string(k.str()), out);
  } else if (const toml::array* a = n.as_array()) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      if ((*a)[i].is_table()) collect_lines((*a)[i], fmt::format("{}[{}]", path, i), out);
    }
  }
}
}  // namespace

std::map<std::string, int> toml_key_lines(const toml::table& root) {
  std::map<std::string, int> out;
  collect_lines(root, "", out);
  return out;
}

}  // namespace kumite
