// Every TOML file content/ reads (dialect maps, motions.toml, characters.toml) goes through
// this one translation unit: the only place in the library that includes toml++.
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "kumite/common/error.hpp"
#include "kumite/content/canonical.hpp"

namespace kumite::content {

namespace {

/// Strict access to one TOML table: every error names file, line and the dotted key;
/// unknown keys are errors (a typo must not be silently ignored).
class Table {
 public:
  Table(const toml::table& t, std::string_view file, std::string prefix, std::string_view component)
      : t_(t), file_(file), prefix_(std::move(prefix)), component_(component) {}

  [[noreturn]] void fail(std::string_view code, std::string_view key, const toml::source_region& where,
                         std::string_view msg) const {
    throw file_error(component_, code, file_, static_cast<int>(where.begin.line), dotted(key), msg);
  }
  [[noreturn]] void fail(std::string_view code, std::string_view key, std::string_view msg) const {
    const toml::node* n = t_.get(key);
    fail(code, key, n ? n->source() : t_.source(), msg);
  }

  std::string dotted(std::string_view key) const { return prefix_.empty() ? std::string(key) : prefix_ + "." + std::string(key); }

  void only(std::initializer_list<std::string_view> allowed) const {
    for (const auto& [k, v] : t_) {
      const std::string_view key = k.str();
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        fail("unknown_key", key, v.source(), "unknown key");
      }
    }
  }

  bool has(std::string_view key) const { return t_.contains(key); }

  std::optional<std::string> opt_string(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail("type", key, "must be a string");
    return std::string(n->as_string()->get());
  }
  std::string string(std::string_view key) const {
    auto v = opt_string(key);
    if (!v) fail("missing_key", key, t_.source(), "is required");
    return *v;
  }
  std::optional<double> opt_number(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    if (auto i = n->value_exact<int64_t>()) return static_cast<double>(*i);
    if (auto d = n->value_exact<double>()) {
      if (!std::isfinite(*d)) fail("not_finite", key, "must be finite");
      return *d;
    }
    fail("type", key, "must be a number");
  }
  double number(std::string_view key) const {
    auto v = opt_number(key);
    if (!v) fail("missing_key", key, t_.source(), "is required");
    return *v;
  }
  std::optional<int64_t> opt_integer(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return std::nullopt;
    if (auto i = n->value_exact<int64_t>()) return *i;
    fail("type", key, "must be an integer");
  }
  int64_t integer(std::string_view key) const {
    auto v = opt_integer(key);
    if (!v) fail("missing_key", key, t_.source(), "is required");
    return *v;
  }
  const toml::table* opt_table(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return nullptr;
    if (!n->is_table()) fail("type", key, "must be a table");
    return n->as_table();
  }
  const toml::array* opt_array(std::string_view key) const {
    const toml::node* n = t_.get(key);
    if (!n) return nullptr;
    if (!n->is_array()) fail("type", key, "must be an array");
    return n->as_array();
  }
  int line(std::string_view key) const {
    const toml::node* n = t_.get(key);
    return static_cast<int>((n ? n->source() : t_.source()).begin.line);
  }
  int line() const { return static_cast<int>(t_.source().begin.line); }
  const toml::table& raw() const { return t_; }

 private:
  const toml::table& t_;
  std::string_view file_;
  std::string prefix_;
  std::string_view component_;
};

toml::table parse_toml(std::string_view text, std::string_view source, std::string_view component) {
  try {
    return toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw file_error(component, "parse", source, static_cast<int>(e.source().begin.line), "",
                     std::string(e.description()));
  }
}

std::string read_text(const std::filesystem::path& path, std::string_view component) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error(component, "io", path.string(), 0, "", "cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

// ---- Dialect maps ---------------------------------------------------------------------------

Dialect parse_dialect_toml(std::string_view text, std::string_view source) {
  const toml::table doc = parse_toml(text, source, "dialect");
  const Table top(doc, source, "", "dialect");
  top.only({"name", "description", "joints"});
  Dialect d;
  d.name = top.string("name");
  if (d.name.empty()) top.fail("value", "name", "must not be empty");
  d.description = top.opt_string("description").value_or("");
  d.source = std::string(source);
  const toml::table* joints = top.opt_table("joints");
  if (!joints) top.fail("missing_key", "joints", doc.source(), "is required ([joints] canonical = \"JointName\")");
  const Table jt(*joints, source, "joints", "dialect");
  std::set<std::string> used;
  for (const auto& [k, v] : *joints) {
    const auto c = canonical_joint_from_string(k.str());
    if (!c) {
      jt.fail("unknown_joint", k.str(), v.source(),
              "not a canonical joint (pelvis, spine, chest, neck, head, l_/r_ clavicle, shoulder, elbow, wrist, "
              "hip, knee, ankle, toe)");
    }
    const std::string name = jt.string(k.str());
    if (name.empty()) jt.fail("value", k.str(), "must not be empty");
    if (!used.insert(name).second) jt.fail("duplicate", k.str(), fmt::format("joint '{}' is mapped twice", name));
    d.joints[static_cast<std::size_t>(*c)] = name;
  }
  return d;
}

Dialect read_dialect_toml(const std::filesystem::path& path) {
  return parse_dialect_toml(read_text(path, "dialect"), path.string());
}

}  // namespace kumite::content
