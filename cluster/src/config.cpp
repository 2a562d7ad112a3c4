// [cluster] of the installation file: one validator per struct (cluster, then each node).
#include <set>

#include <fmt/format.h>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"

namespace kumite::cluster {

namespace {

constexpr std::string_view kComponent = "config";

void check_endpoint(const TomlTable& t, std::string_view key, const std::string& e) {
  const bool tcp = e.rfind("tcp://", 0) == 0 && e.size() > 6;
  const bool ipc = e.rfind("ipc://", 0) == 0 && e.size() > 6;
  if (!tcp && !ipc)
    t.fail("range", key, fmt::format("\"{}\": an endpoint is tcp://HOST:PORT or ipc://PATH", e));
  if (tcp && e.find(':', 6) == std::string::npos) t.fail("range", key, fmt::format("\"{}\": tcp:// needs a :PORT", e));
}

std::vector<std::string> names(const TomlTable& t, std::string_view key) {
  std::vector<std::string> out;
  const toml::array* a = t.opt_array(key);
  if (!a) return out;
  for (const auto& n : *a) {
    const auto* s = n.as_string();
    if (!s || s->get().empty()) t.fail_at(n, "type", key, "must be an array of names (non-empty strings)");
    out.push_back(s->get());
  }
  return out;
}

/// One [[cluster.nodes]] table.
NodeConfig read_node(const TomlTable& t) {
  t.only({"name", "address", "walls", "windows", "swap_group", "swap_barrier"});
  NodeConfig n;
  n.line = t.line();
  n.name = t.string("name", false);
  n.address = t.opt_string("address", false);
  n.walls = names(t, "walls");
  n.windows = names(t, "windows");
  if (const auto g = t.opt_integer("swap_group", 1, 16)) n.swap_group = static_cast<int>(*g);
  if (const auto b = t.opt_integer("swap_barrier", 1, 16)) n.swap_barrier = static_cast<int>(*b);
  if (n.swap_barrier && !n.swap_group)
    t.fail("missing_key", "swap_barrier", "binds a swap group to a barrier: give swap_group too");
  if (n.walls.empty()) t.fail("missing_key", "walls", "a node draws at least one wall (walls = [\"front\"])");
  std::set<std::string> seen;
  for (const auto& w : n.walls)
    if (!seen.insert(w).second) t.fail("range", "walls", fmt::format("wall \"{}\" listed twice", w));
  return n;
}

}  // namespace

const NodeConfig* ClusterConfig::node(std::string_view name) const {
  for (const auto& n : nodes)
    if (n.name == name) return &n;
  return nullptr;
}

std::optional<ClusterConfig> parse_cluster_config(std::string_view text, std::string_view file) {
  const toml::table doc = parse_toml(text, file, kComponent);
  const TomlTable root(doc, kComponent, file);
  const auto t = root.opt_table("cluster");
  if (!t) return std::nullopt;
  t->only({"state", "control", "state_bind", "control_bind", "deadline_ms", "max_misses", "master_lost_ms", "nodes"});
  ClusterConfig c;
  c.state = t->string("state", false);
  c.control = t->string("control", false);
  check_endpoint(*t, "state", c.state);
  check_endpoint(*t, "control", c.control);
  if (c.state == c.control) t->fail("range", "control", "must differ from state (two sockets)");
  c.state_bind = t->opt_string("state_bind", false);
  c.control_bind = t->opt_string("control_bind", false);
  if (c.state_bind) check_endpoint(*t, "state_bind", *c.state_bind);
  if (c.control_bind) check_endpoint(*t, "control_bind", *c.control_bind);
  c.deadline_ms = t->opt_number("deadline_ms", {0.1, 10000, "ms"});
  t->read("max_misses", c.max_misses, 1, 1000);
  t->read("master_lost_ms", c.master_lost_ms, {10, 60000, "ms"});
  std::set<std::string> seen;
  for (const TomlTable& nt : t->tables("nodes")) {
    NodeConfig n = read_node(nt);
    if (!seen.insert(n.name).second) nt.fail("range", "name", fmt::format("node \"{}\" named twice", n.name));
    c.nodes.push_back(std::move(n));
  }
  if (c.nodes.empty()) t->fail("missing_key", "nodes", "a cluster has at least one [[cluster.nodes]]");
  return c;
}

}  // namespace kumite::cluster
