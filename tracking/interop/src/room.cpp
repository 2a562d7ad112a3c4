// Kumite's room from DTrack's: the room transform, the body-id -> role map ([dtrack] of a TOML
// file, through the project's strict TOML reader) and the conversions between DtrackFrame and
// RoomFrame.
#include <arpa/inet.h>

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"
#include "kumite/tracking/interop.hpp"

namespace kumite::tracking {

namespace {

using Mat = std::array<double, 9>;
using Vec = std::array<double, 3>;

Mat mul(const Mat& a, const Mat& b) {
  Mat c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += a[static_cast<std::size_t>(i * 3 + k)] * b[static_cast<std::size_t>(k * 3 + j)];
      c[static_cast<std::size_t>(i * 3 + j)] = s;
    }
  return c;
}
Mat transpose(const Mat& a) { return {a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]}; }
Vec mul(const Mat& a, const Vec& v) {
  return {a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
          a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
}

}  // namespace

int role_index(std::string_view name) {
  for (std::size_t i = 0; i < kRoleNames.size(); ++i)
    if (kRoleNames[i] == name) return static_cast<int>(i);
  return -1;
}

RoomTransform RoomTransform::z_up() {
  RoomTransform t;
  t.rotation = {1, 0, 0, 0, 0, 1, 0, -1, 0};  // (x, y, z) -> (x, z, -y)
  return t;
}

RoomTransform RoomTransform::inverse() const {
  RoomTransform inv;
  inv.rotation = transpose(rotation);
  const Vec t = mul(inv.rotation, translation_m);
  inv.translation_m = {-t[0], -t[1], -t[2]};
  inv.conjugate_body = conjugate_body;
  return inv;
}

std::array<double, 3> RoomTransform::apply_position(const std::array<double, 3>& p) const {
  const Vec r = mul(rotation, p);
  return {r[0] + translation_m[0], r[1] + translation_m[1], r[2] + translation_m[2]};
}

std::array<double, 9> RoomTransform::apply_rotation(const std::array<double, 9>& r) const {
  const Mat a = mul(rotation, r);
  return conjugate_body ? mul(a, transpose(rotation)) : a;
}

std::array<double, 4> quaternion_from_rotation(const std::array<double, 9>& r) {
  Eigen::Matrix3d m;
  m << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  Eigen::Quaterniond q(m);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1;  // one of the two: w >= 0
  return {q.w(), q.x(), q.y(), q.z()};
}

std::array<double, 9> rotation_from_quaternion(const std::array<double, 4>& q) {
  const Eigen::Matrix3d m = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  return {m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2)};
}

bool DtrackInput::has_roles() const {
  return std::any_of(role_body.begin(), role_body.end(), [](std::int32_t id) { return id >= 0; });
}

int DtrackInput::role_of(std::int32_t id) const {
  for (std::size_t i = 0; i < role_body.size(); ++i)
    if (role_body[i] == id && id >= 0) return static_cast<int>(i);
  return -1;
}

const RoomBody* find_role(const RoomFrame& frame, std::string_view role, bool tracked_only) {
  const int r = role_index(role);
  if (r < 0) return nullptr;
  for (int i = 0; i < frame.body_count; ++i) {
    const RoomBody& b = frame.bodies[static_cast<std::size_t>(i)];
    if (b.role == r && b.kind == RoomBodyKind::body) return (tracked_only && !b.tracked) ? nullptr : &b;
  }
  return nullptr;
}

const RoomBody* find_body(const RoomFrame& frame, std::int32_t id, RoomBodyKind kind) {
  for (int i = 0; i < frame.body_count; ++i) {
    const RoomBody& b = frame.bodies[static_cast<std::size_t>(i)];
    if (b.id == id && b.kind == kind) return &b;
  }
  return nullptr;
}

int to_room_frame(const DtrackFrame& in, const DtrackInput& input, RoomFrame& out) {
  out.frame = in.frame;
  out.source_time_s = in.timestamp_s;
  out.latency_us = in.latency_us;
  out.body_count = 0;
  out.bodies_dropped = 0;
  int unconfigured = 0;
  const bool roles = input.has_roles();
  auto add = [&](const DtrackBody& b, RoomBodyKind kind, int role) {
    if (out.body_count >= kRoomFrameBodies) {
      ++out.bodies_dropped;
      return;
    }
    RoomBody& r = out.bodies[static_cast<std::size_t>(out.body_count++)];
    r = RoomBody{};
    r.id = b.id;
    r.role = role;
    r.kind = kind;
    r.tracked = b.tracked();
    r.quality = b.quality;
    if (r.tracked) {
      const Mat rot = input.room.apply_rotation(b.rotation);
      r.position_m = input.room.apply_position(b.position_m);
      if (role >= 0) {  // the point of interest, not DTrack's body origin ([dtrack.offsets])
        const Vec d = mul(rot, input.role_offset_m[static_cast<std::size_t>(role)]);
        for (std::size_t k = 0; k < 3; ++k) r.position_m[k] += d[k];
      }
      r.orientation = quaternion_from_rotation(rot);
    }
  };
  for (const auto& b : in.bodies) {
    const int role = input.role_of(b.id);
    if (roles && role < 0) {
      ++unconfigured;
      continue;
    }
    add(b, RoomBodyKind::body, role);
  }
  for (const auto& f : in.flysticks) add(f.pose, RoomBodyKind::flystick, -1);
  return unconfigured;
}

void to_dtrack_frame(const RoomFrame& in, const RoomTransform& room, DtrackFrame& out) {
  out.clear();
  out.has_frame = true;
  out.frame = in.frame;
  out.timestamp_s = in.source_time_s;
  const RoomTransform back = room.inverse();
  for (int i = 0; i < in.body_count; ++i) {
    const RoomBody& r = in.bodies[static_cast<std::size_t>(i)];
    if (r.kind != RoomBodyKind::body) continue;
    DtrackBody b;
    b.id = r.id;
    b.quality = r.tracked ? 1.0 : -1.0;
    if (r.tracked) {
      b.position_m = back.apply_position(r.position_m);
      b.rotation = back.apply_rotation(rotation_from_quaternion(r.orientation));
    }
    out.bodies.push_back(b);
  }
  out.calibrated_bodies = static_cast<std::int32_t>(out.bodies.size());
}

// --- [dtrack] ------------------------------------------------------------------------------

namespace {

void read_dtrack_table(const TomlTable* t, DtrackInput& cfg) {
  t->only({"port", "bind_address", "multicast_group", "room_axes", "rotation", "translation_m", "conjugate_body",
           "bodies", "offsets"});
  t->read("port", cfg.port, 1, 65535);
  if (t->read("bind_address", cfg.bind_address, false)) {
    in_addr a{};
    if (inet_pton(AF_INET, cfg.bind_address.c_str(), &a) != 1)
      t->fail("value", "bind_address", fmt::format("'{}' is not an IPv4 address", cfg.bind_address));
  }
  if (t->read("multicast_group", cfg.multicast_group, true) && !cfg.multicast_group.empty()) {
    in_addr a{};
    if (inet_pton(AF_INET, cfg.multicast_group.c_str(), &a) != 1 || (ntohl(a.s_addr) >> 28) != 0xE)
      t->fail("value", "multicast_group",
              fmt::format("'{}' is not an IPv4 multicast address (224.0.0.0 to 239.255.255.255)", cfg.multicast_group));
  }
  if (const auto axes = t->opt_string("room_axes")) {
    if (*axes == "z_up") cfg.room = RoomTransform::z_up();
    else if (*axes == "y_up") cfg.room = RoomTransform::y_up();
    else t->fail("value", "room_axes", fmt::format("'{}': z_up (DTrack's default room) or y_up", *axes));
  }
  if (const toml::array* rows = t->opt_array("rotation")) {
    if (rows->size() != 3) t->fail_at(*rows, "type", "rotation", "must be 3 rows [[r00, r01, r02], [...], [...]]");
    Mat m{};
    for (std::size_t i = 0; i < 3; ++i) {
      const auto* row = (*rows)[i].as_array();
      if (!row || row->size() != 3) t->fail_at((*rows)[i], "type", "rotation", "each row must be 3 numbers");
      for (std::size_t j = 0; j < 3; ++j) {
        const toml::node& e = (*row)[j];
        const std::optional<double> v = e.is_number() ? e.value<double>() : std::nullopt;
        if (!v) t->fail_at(e, "type", "rotation", "must be numbers");
        if (!std::isfinite(*v)) t->fail_at(e, "not_finite", "rotation", "must be a finite number");
        m[i * 3 + j] = *v;
      }
    }
    const Mat p = mul(m, transpose(m));
    double worst = 0;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        worst = std::max(worst, std::abs(p[static_cast<std::size_t>(i * 3 + j)] - (i == j ? 1.0 : 0.0)));
    const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                       m[2] * (m[3] * m[7] - m[4] * m[6]);
    if (worst > 1e-3 || det < 0)
      t->fail("value", "rotation",
              fmt::format("not a rotation (|R·Rᵀ - I| = {:.3g}, det {:.3g}): rows must be orthonormal, det +1", worst,
                          det));
    cfg.room.rotation = rotation_from_quaternion(quaternion_from_rotation(m));  // orthonormal to the last digit
  }
  t->read("translation_m", cfg.room.translation_m, {-100, 100, "m"});
  t->read("conjugate_body", cfg.room.conjugate_body);
  if (const auto bodies = t->opt_table("bodies")) {
    std::vector<std::string_view> roles(kRoleNames.begin(), kRoleNames.end());
    bodies->only(roles);
    for (std::size_t r = 0; r < kRoleNames.size(); ++r) {
      if (const auto id = bodies->opt_integer(kRoleNames[r], 0, kDtrackMaxBodies - 1)) {
        const int other = cfg.role_of(static_cast<std::int32_t>(*id));
        if (other >= 0)
          bodies->fail("value", kRoleNames[r],
                       fmt::format("body {} is already {}", *id, kRoleNames[static_cast<std::size_t>(other)]));
        cfg.role_body[r] = static_cast<std::int32_t>(*id);
      }
    }
  }
  if (const auto offsets = t->opt_table("offsets")) {
    std::vector<std::string_view> roles(kRoleNames.begin(), kRoleNames.end());
    offsets->only(roles);
    for (std::size_t r = 0; r < kRoleNames.size(); ++r)
      offsets->read(kRoleNames[r], cfg.role_offset_m[r], {-1, 1, "m"});
  }
}

/// The table at the dotted `rest` below `t` (nothing when absent).
void walk(const TomlTable& t, std::string_view rest, DtrackInput& cfg) {
  if (rest.empty()) return read_dtrack_table(&t, cfg);
  const std::size_t dot = rest.find('.');
  const auto sub = t.opt_table(rest.substr(0, dot));
  if (!sub) return;
  walk(*sub, dot == std::string_view::npos ? std::string_view{} : rest.substr(dot + 1), cfg);
}

}  // namespace

DtrackInput parse_dtrack_config(std::string_view text, std::string_view file, std::string_view table_path) {
  DtrackInput cfg;
  const toml::table doc = parse_toml(text, file, "dtrack");
  walk(TomlTable(doc, "dtrack", file), table_path, cfg);
  return cfg;
}

DtrackInput read_dtrack_config(const std::string& path, std::string_view table_path) {
  return parse_dtrack_config(read_text_file(path, "dtrack"), path, table_path);
}

}  // namespace kumite::tracking
