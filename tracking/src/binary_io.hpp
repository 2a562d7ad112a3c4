#pragma once
// Little-endian fields of the tracking library's binary records (PackedImage, cameras.bin):
// put() appends a value's bytes, get() takes them from the front of a view (false, and the
// view untouched, when too few are left). Hosts are little-endian (x86-64, aarch64): the
// file's order. Internal to the tracking library.
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>

namespace kumite::tracking::binary {

template <typename T>
void put(std::string& out, T v) {
  static_assert(std::is_trivially_copyable_v<T>);
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

template <typename T>
bool get(std::string_view& in, T& v) {
  static_assert(std::is_trivially_copyable_v<T>);
  if (in.size() < sizeof(T)) return false;
  std::memcpy(&v, in.data(), sizeof(T));
  in.remove_prefix(sizeof(T));
  return true;
}

}  // namespace kumite::tracking::binary
