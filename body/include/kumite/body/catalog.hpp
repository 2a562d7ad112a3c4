#pragma once
// Which body each character wears: body/assets/bodies.toml.
//
//   version = 1
//   [[body]]
//   character = "kenji"              # a name in content/characters/characters.toml
//   model = "male_casual.glb"        # relative to bodies.toml
//   outfit = [0.05, 0.09, 0.30]      # linear RGB, each in [0, 1]
//   outfit_materials = ["Purple"]    # the model's materials drawn in the outfit colour
//
// Read with the project's strict TOML reader: errors are one line "file:line: key: message".
#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/body/model.hpp"

namespace kumite::body {

struct BodyEntry {
  std::string character;
  std::string model;  ///< as written
  std::array<float, 3> outfit{1, 1, 1};
  std::vector<std::string> outfit_materials;
  int line = 0;
};

struct BodyCatalog {
  std::vector<BodyEntry> bodies;
  std::filesystem::path source;
  std::filesystem::path resolve(const BodyEntry& e) const;
  const BodyEntry* find(std::string_view character) const;  ///< nullptr when absent
};

inline constexpr int kBodyCatalogVersion = 1;
BodyCatalog parse_bodies(std::string_view text, std::string_view source);
BodyCatalog read_bodies(const std::filesystem::path& path);

/// Sets the outfit colour on the entry's materials (RGB; alpha kept). Throws kumite::Error
/// "file:line: outfit_materials: ..." naming a material the model does not have.
void apply_outfit(SkinnedModel& model, const BodyCatalog& catalog, const BodyEntry& entry);

}  // namespace kumite::body
