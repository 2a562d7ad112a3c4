// bodies.toml (catalog.hpp), read through the strict TOML reader.
#include "kumite/body/catalog.hpp"

#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"

namespace kumite::body {

std::filesystem::path BodyCatalog::resolve(const BodyEntry& e) const { return source.parent_path() / e.model; }

const BodyEntry* BodyCatalog::find(std::string_view character) const {
  for (const auto& b : bodies)
    if (b.character == character) return &b;
  return nullptr;
}

BodyCatalog parse_bodies(std::string_view text, std::string_view source) {
  const toml::table doc = parse_toml(text, source, "body");
  const TomlTable root(doc, "body", source);
  root.only({"version", "body"});
  root.integer("version", kBodyCatalogVersion, kBodyCatalogVersion);
  BodyCatalog out;
  out.source = std::filesystem::path(source);
  for (const TomlTable& t : root.tables("body")) {
    t.only({"character", "model", "outfit", "outfit_materials"});
    BodyEntry e;
    e.line = t.line();
    e.character = t.string("character", false);
    e.model = t.string("model", false);
    if (out.find(e.character)) t.fail("duplicate", "character", "\"" + e.character + "\" has a body already");
    std::array<double, 3> c{};
    if (!t.read("outfit", c, TomlRange{0, 1, ""})) t.fail("missing_key", "outfit", "is required");
    for (std::size_t i = 0; i < 3; ++i) e.outfit[i] = static_cast<float>(c[i]);
    if (const toml::array* a = t.opt_array("outfit_materials")) {
      for (const toml::node& n : *a) {
        const auto s = n.value<std::string>();
        if (!s || s->empty()) t.fail_at(n, "type", "outfit_materials", "must be material names (non-empty strings)");
        e.outfit_materials.push_back(*s);
      }
    }
    out.bodies.push_back(std::move(e));
  }
  if (out.bodies.empty()) root.fail("missing_key", "body", "at least one [[body]] is required");
  return out;
}

BodyCatalog read_bodies(const std::filesystem::path& path) {
  return parse_bodies(read_text_file(path, "body"), path.string());
}

void apply_outfit(SkinnedModel& model, const BodyCatalog& catalog, const BodyEntry& entry) {
  for (const std::string& name : entry.outfit_materials) {
    bool found = false;
    for (Material& m : model.materials)
      if (m.name == name) {
        for (std::size_t i = 0; i < 3; ++i) m.base_color[i] = entry.outfit[i];
        found = true;
      }
    if (!found)
      throw file_error("body", "material", catalog.source.string(), entry.line, "outfit_materials",
                       model.source + " has no material \"" + name + "\"");
  }
}

}  // namespace kumite::body
