#pragma once
// Shared access to the development mocap set (../shared/data/mocap) for the content tests.
// Each file is parsed at most once per test binary. Tests skip when the data is absent.
#include <filesystem>
#include <map>
#include <string>

#include "kumite/content/bvh.hpp"

namespace kumite::content::testing {

inline std::filesystem::path mocap_dir() {
  return std::filesystem::path(KUMITE_SHARED_DATA_DIR) / "mocap";
}
inline bool have_mocap() { return std::filesystem::exists(mocap_dir() / "cmu" / "135_04.bvh"); }

/// "cmu/135_04" or "assimp/Boxing_Toes" -> the parsed clip (cached).
inline const Clip& mocap_clip(const std::string& rel) {
  static std::map<std::string, Clip> cache;
  auto it = cache.find(rel);
  if (it == cache.end()) it = cache.emplace(rel, read_bvh(mocap_dir() / (rel + ".bvh"))).first;
  return it->second;
}

inline std::filesystem::path source_dir() { return KUMITE_SOURCE_DIR; }

}  // namespace kumite::content::testing

#define KUMITE_REQUIRE_MOCAP()                                                         \
  do {                                                                                 \
    if (!kumite::content::testing::have_mocap())                                       \
      GTEST_SKIP() << "no shared mocap data at " << kumite::content::testing::mocap_dir(); \
  } while (0)
