// The project's one strict TOML reader: every file people edit reports mistakes through it,
// as "file:line: key: message" with a stable code.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "kumite/common/error.hpp"
#include "kumite/common/toml_reader.hpp"

using namespace kumite;

namespace {

struct Failure {
  std::string code, what;
};

/// Parses `text` as "f.toml" and runs `read` on its root table; the error it throws, if any.
template <typename F>
Failure failure_of(const std::string& text, F&& read) {
  try {
    const toml::table doc = parse_toml(text, "f.toml", "test");
    read(TomlTable(doc, "test", "f.toml"));
  } catch (const Error& e) {
    return {e.code(), e.what()};
  }
  return {"", "no error"};
}

}  // namespace

TEST(TomlReader, NumbersAreFiniteInRangeAndOfTheirType) {
  const auto number = [](const TomlTable& t) { t.number("x", {0, 100, "ms"}); };
  for (const char* bad : {"nan", "+nan", "-nan", "inf", "+inf", "-inf"}) {
    const Failure f = failure_of(std::string("\n\nx = ") + bad + "\n", number);
    EXPECT_EQ(f.code, "not_finite") << bad;
    EXPECT_EQ(f.what, "f.toml:3: x: must be a finite number") << bad;
  }
  EXPECT_EQ(failure_of("x = 120\n", number).what, "f.toml:1: x: must be in [0, 100] ms, found 120");
  EXPECT_EQ(failure_of("x = 120\n", number).code, "range");
  EXPECT_EQ(failure_of("x = -0.5\n", [](const TomlTable& t) { t.number("x", TomlRange::at_least(0)); }).what,
            "f.toml:1: x: must be >= 0, found -0.5");
  EXPECT_EQ(failure_of("x = \"1\"\n", number).what, "f.toml:1: x: must be a number");
  EXPECT_EQ(failure_of("y = 1\n", number).what, "f.toml:1: x: is required");
  EXPECT_EQ(failure_of("y = 1\n", number).code, "missing_key");
  // An integer is a number; a float is not an integer.
  EXPECT_EQ(failure_of("x = 7\n", number).what, "no error");
  EXPECT_EQ(failure_of("x = 7.5\n", [](const TomlTable& t) { t.integer("x"); }).what,
            "f.toml:1: x: must be an integer");
  EXPECT_EQ(failure_of("x = 70\n", [](const TomlTable& t) { t.integer("x", 1, 64); }).what,
            "f.toml:1: x: must be in [1, 64], found 70");
}

TEST(TomlReader, ValuesReadBackAndAbsentKeysLeaveDefaults) {
  const toml::table doc = parse_toml("a = 1.5\nb = 3\nc = true\nd = \"x\"\ne = [1, 2.5, -3]\n", "f.toml", "test");
  const TomlTable t(doc, "test", "f.toml");
  double a = 0, z = 9;
  int b = 0;
  bool c = false;
  std::string d;
  std::array<double, 3> e{};
  EXPECT_TRUE(t.read("a", a));
  EXPECT_TRUE(t.read("b", b));
  EXPECT_TRUE(t.read("c", c));
  EXPECT_TRUE(t.read("d", d));
  EXPECT_TRUE(t.read("e", e));
  EXPECT_FALSE(t.read("z", z));
  EXPECT_EQ(a, 1.5);
  EXPECT_EQ(b, 3);
  EXPECT_TRUE(c);
  EXPECT_EQ(d, "x");
  EXPECT_EQ(e, (std::array<double, 3>{1, 2.5, -3}));
  EXPECT_EQ(z, 9);  // untouched
}

TEST(TomlReader, UnknownKeysNameWhatIsAllowedAndNestedKeysTheirPath) {
  const auto read = [](const TomlTable& t) {
    t.only({"walls", "fighter"});
    for (const TomlTable& w : t.tables("walls")) w.only({"name"});
    if (auto f = t.opt_table("fighter")) {
      f->only({"behaviour"});
      if (auto b = f->opt_table("behaviour")) b->number("walk_speed_mps", {0.1, 3, "m/s"});
    }
  };
  EXPECT_EQ(failure_of("colour = 1\n", read).what, "f.toml:1: colour: unknown key (allowed here: walls, fighter)");
  EXPECT_EQ(failure_of("colour = 1\n", read).code, "unknown_key");
  EXPECT_EQ(failure_of("[[walls]]\nname = 1\n[[walls]]\nnmae = 2\n", read).what,
            "f.toml:4: walls[1].nmae: unknown key (allowed here: name)");
  EXPECT_EQ(failure_of("[fighter.behaviour]\nwalk_speed_mps = nan\n", read).what,
            "f.toml:2: fighter.behaviour.walk_speed_mps: must be a finite number");
  EXPECT_EQ(failure_of("fighter = 3\n", read).what, "f.toml:1: fighter: must be a table");
  EXPECT_EQ(failure_of("walls = 3\n", read).what, "f.toml:1: walls: must be an array");
  EXPECT_EQ(failure_of("walls = [1]\n", read).what, "f.toml:1: walls[0]: must be a table ([[walls]])");
}

TEST(TomlReader, StringsPathsAndArraysAreChecked) {
  EXPECT_EQ(failure_of("p = \"\"\n", [](const TomlTable& t) { std::filesystem::path p; t.read("p", p); }).what,
            "f.toml:1: p: must not be empty");
  EXPECT_EQ(failure_of("p = \"\"\n", [](const TomlTable& t) { std::filesystem::path p; t.read("p", p); }).code,
            "empty");
  EXPECT_EQ(failure_of("s = 3\n", [](const TomlTable& t) { t.string("s"); }).what, "f.toml:1: s: must be a string");
  EXPECT_EQ(failure_of("b = 1\n", [](const TomlTable& t) { bool b; t.read("b", b); }).what,
            "f.toml:1: b: must be true or false");
  const auto three = [](const TomlTable& t) { std::array<double, 3> v; t.read("v", v, {-10, 10, "m"}); };
  EXPECT_EQ(failure_of("v = [1, 2]\n", three).what, "f.toml:1: v: must be an array of 3 numbers");
  EXPECT_EQ(failure_of("v = [1, 2, nan]\n", three).what, "f.toml:1: v: must be a finite number");
  EXPECT_EQ(failure_of("v = [1, 2, 11]\n", three).what, "f.toml:1: v: must be in [-10, 10] m, found 11");
}

TEST(TomlReader, FileErrorsNameTheFile) {
  EXPECT_EQ(failure_of("x = [\n", [](const TomlTable&) {}).code, "parse");
  EXPECT_NE(failure_of("x = [\n", [](const TomlTable&) {}).what.find("f.toml:1"), std::string::npos);
  const auto dir = std::filesystem::temp_directory_path();
  try {
    read_text_file(dir, "test");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir.string() + ": is a folder, not a file");
  }
  try {
    read_text_file(dir / "kumite-no-such-file.toml", "test");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), "io");
  }
}

TEST(TomlReader, KeyLinesCoverEveryKeyByItsPath) {
  const toml::table doc =
      parse_toml("a = 1\n[[walls]]\nname = \"f\"\n[[walls]]\nname = \"l\"\n[fighter.behaviour]\nx = 2\n", "f.toml", "test");
  const auto lines = toml_key_lines(doc);
  EXPECT_EQ(lines.at("a"), 1);
  EXPECT_EQ(lines.at("walls[0].name"), 3);
  EXPECT_EQ(lines.at("walls[1]"), 4);
  EXPECT_EQ(lines.at("walls[1].name"), 5);
  EXPECT_EQ(lines.at("fighter.behaviour.x"), 7);
}
