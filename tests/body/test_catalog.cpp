// bodies.toml: every shipped character has a body that loads, maps and takes its outfit;
// mistakes are one line "file:line: key: message".
#include <gtest/gtest.h>

#include <filesystem>

#include "kumite/body/catalog.hpp"
#include "kumite/body/retarget.hpp"
#include "kumite/common/error.hpp"
#include "kumite/content/character.hpp"

namespace fs = std::filesystem;
using namespace kumite;
using namespace kumite::body;

TEST(Catalog, EveryShippedCharacterHasABodyThatLoadsMapsAndTakesItsOutfit) {
  const BodyCatalog cat = read_bodies(fs::path(KUMITE_SOURCE_DIR) / "body" / "assets" / "bodies.toml");
  const auto chars = content::read_characters(fs::path(KUMITE_SOURCE_DIR) / "content" / "characters" / "characters.toml");
  ASSERT_EQ(chars.characters.size(), 5u);
  for (const auto& c : chars.characters) {
    SCOPED_TRACE(c.name);
    const BodyEntry* e = cat.find(c.name);
    ASSERT_NE(e, nullptr);
    SkinnedModel m = load_model(cat.resolve(*e));
    apply_outfit(m, cat, *e);
    ASSERT_NE(detect_bone_map(m.skeleton.names), nullptr);
    bool tinted = false;
    for (const auto& mat : m.materials) tinted |= mat.base_color[0] == e->outfit[0] && mat.base_color[2] == e->outfit[2];
    EXPECT_TRUE(tinted);
  }
}

TEST(Catalog, MistakesAreOneLineNamingFileLineAndKey) {
  auto why = [](std::string_view text) {
    try {
      parse_bodies(text, "bodies.toml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(why("version = 1\n[[body]]\ncharacter = \"kenji\"\nmodel = \"a.glb\"\noutfit = [0.5, 2, 0]\n"),
            "bodies.toml:5: body[0].outfit: must be in [0, 1], found 2");
  EXPECT_NE(why("version = 1\n[[body]]\ncharacter = \"kenji\"\nmodel = \"a.glb\"\noutfit = [0, 0, 0]\ncolour = 1\n").find("bodies.toml:6: body[0].colour: unknown key"), std::string::npos);
  EXPECT_NE(why("version = 1\n[[body]]\ncharacter = \"kenji\"\noutfit = [0, 0, 0]\n").find("body[0].model: is required"), std::string::npos);
  EXPECT_NE(why("version = 2\n").find("bodies.toml:1: version"), std::string::npos);
  const BodyCatalog cat = parse_bodies("version = 1\n[[body]]\ncharacter = \"kenji\"\nmodel = \"male_casual.glb\"\noutfit = [0, 0, 0]\noutfit_materials = [\"Nope\"]\n",
                                       (fs::path(KUMITE_SOURCE_DIR) / "body" / "assets" / "bodies.toml").string());
  SkinnedModel m = load_model(cat.resolve(cat.bodies[0]));
  try {
    apply_outfit(m, cat, cat.bodies[0]);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bodies.toml:2: outfit_materials: "), std::string::npos) << e.what();
  }
}
