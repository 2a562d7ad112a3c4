#include <cmath>
#include <cstring>

#include "kumite/cluster/cluster.hpp"
#include "kumite/common/checksum.hpp"

namespace kumite::cluster {

namespace {
constexpr std::uint32_t kMagic = 0x314C434B;  // "KCL1"

template <typename T>
void put(char* at, T v) {
  std::memcpy(at, &v, sizeof v);
}
template <typename T>
T get(const char* at) {
  T v;
  std::memcpy(&v, at, sizeof v);
  return v;
}
}  // namespace

std::string_view to_string(Defect d) {
  switch (d) {
    case Defect::none: return "none";
    case Defect::cut: return "cut short";
    case Defect::oversized: return "oversized";
    case Defect::bad_magic: return "not a cluster message";
    case Defect::wrong_version: return "another protocol version";
    case Defect::wrong_config: return "another installation file";
    case Defect::bad_type: return "unknown message type";
    case Defect::not_finite: return "master time not finite";
  }
  return "?";
}

void DefectCounts::count(Defect d) {
  switch (d) {
    case Defect::none: break;
    case Defect::cut: ++cut; break;
    case Defect::oversized: ++oversized; break;
    case Defect::bad_magic: ++bad_magic; break;
    case Defect::wrong_version: ++wrong_version; break;
    case Defect::wrong_config: ++wrong_config; break;
    case Defect::bad_type: ++bad_type; break;
    case Defect::not_finite: ++not_finite; break;
  }
}

void encode_message(const Header& h, std::span<const std::byte> payload, std::string& out) {
  out.resize(kHeaderBytes + payload.size());
  char* p = out.data();
  put<std::uint32_t>(p, kMagic);
  put<std::uint16_t>(p + 4, kProtocolVersion);
  put<std::uint8_t>(p + 6, static_cast<std::uint8_t>(h.type));
  put<std::uint8_t>(p + 7, 0);
  put<std::uint64_t>(p + 8, h.config_hash);
  put<std::uint64_t>(p + 16, h.frame);
  put<double>(p + 24, h.master_time_s);
  put<std::uint32_t>(p + 32, static_cast<std::uint32_t>(payload.size()));
  put<std::uint32_t>(p + 36, 0);
  if (!payload.empty()) std::memcpy(p + kHeaderBytes, payload.data(), payload.size());
}

Defect decode_message(std::string_view bytes, std::uint64_t config_hash, Header& h, std::string_view& payload) {
  if (bytes.size() > kHeaderBytes + kMaxPayloadBytes) return Defect::oversized;
  if (bytes.size() < 8) return Defect::cut;
  const char* p = bytes.data();
  if (get<std::uint32_t>(p) != kMagic) return Defect::bad_magic;
  if (get<std::uint16_t>(p + 4) != kProtocolVersion) return Defect::wrong_version;
  if (bytes.size() < kHeaderBytes) return Defect::cut;
  const auto type = get<std::uint8_t>(p + 6);
  if (type < 1 || type > 8) return Defect::bad_type;
  const auto n = get<std::uint32_t>(p + 32);
  if (n > kMaxPayloadBytes) return Defect::oversized;
  if (bytes.size() != kHeaderBytes + n) return bytes.size() < kHeaderBytes + n ? Defect::cut : Defect::oversized;
  h.type = static_cast<MessageType>(type);
  h.config_hash = get<std::uint64_t>(p + 8);
  h.frame = get<std::uint64_t>(p + 16);
  h.master_time_s = get<double>(p + 24);
  h.payload_bytes = n;
  if (!std::isfinite(h.master_time_s)) return Defect::not_finite;
  // HELLO carries the node's hash for the master to compare, REFUSED the master's to say why;
  // everything else of another installation file is dropped here.
  if (h.config_hash != config_hash && h.type != MessageType::hello && h.type != MessageType::refused)
    return Defect::wrong_config;
  payload = bytes.substr(kHeaderBytes, n);
  return Defect::none;
}

std::uint64_t config_hash(std::string_view file_text) { return fnv1a64(file_text); }

}  // namespace kumite::cluster
