// kumite-recognise as a technician runs it: from a copied bin folder, and on a poses file the
// recogniser cannot use.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "kumite/recognition/poses_file.hpp"

namespace fs = std::filesystem;

namespace {

struct Tmp {
  fs::path path = fs::temp_directory_path() / ("kumite_recognise_tool_" + std::to_string(::getpid()));
  Tmp() {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~Tmp() { fs::remove_all(path); }
};

/// Runs `command` in a shell: its exit status, and stdout and stderr together in `out`.
int run(const std::string& command, std::string& out) {
  out.clear();
  FILE* p = ::popen((command + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  const int status = ::pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

const fs::path kTool = fs::path(KUMITE_BINARY_DIR) / "bin" / "kumite-recognise";

}  // namespace

// Copied out of its checkout, the tool finds no shipped model beside it and says so at once,
// naming where it looked (it read another checkout's model through a path compiled in, and said
// so only in its summary).
TEST(RecogniseTool, ACopiedToolLooksForItsModelBesideItselfAndSaysWhere) {
  if (!fs::exists(kTool)) GTEST_SKIP() << kTool << " not built";
  Tmp tmp;
  fs::create_directories(tmp.path / "site" / "bin");
  fs::copy_file(kTool, tmp.path / "site" / "bin" / "kumite-recognise");
  const std::string poses = std::string(KUMITE_SOURCE_DIR) + "/config/visitor-135_06.poses.csv";
  std::string out;
  const int rc = run((tmp.path / "site" / "bin" / "kumite-recognise").string() + " run --poses " + poses + " --out " +
                         (tmp.path / "events.jsonl").string(),
                     out);
  EXPECT_NE(rc, 0) << out;
  EXPECT_NE(out.find("no --model given"), std::string::npos) << out;
  EXPECT_NE(out.find((tmp.path / "recognition" / "models" / "strikes.krec").string()), std::string::npos) << out;
  EXPECT_FALSE(fs::exists(tmp.path / "events.jsonl"));
  // In its checkout it names the model it uses before it starts.
  ASSERT_EQ(run(kTool.string() + " run --poses " + poses + " --out " + (tmp.path / "events.jsonl").string(), out), 0) << out;
  EXPECT_NE(out.find("kumite-recognise run: model " + std::string(KUMITE_SOURCE_DIR)), std::string::npos) << out;
}

// A poses file without the head: nothing can be recognised, and the tool says why (it said
// nothing: 0 events, exit 0), as kumite does for the same file.
TEST(RecogniseTool, APosesFileWithoutTheHeadIsSaid) {
  if (!fs::exists(kTool)) GTEST_SKIP() << kTool << " not built";
  Tmp tmp;
  std::ifstream in(std::string(KUMITE_SOURCE_DIR) + "/config/visitor-135_06.poses.csv");
  std::ofstream headless(tmp.path / "nohead.csv");
  for (std::string line; std::getline(in, line);)
    if (line.find(",head,") == std::string::npos) headless << line << "\n";
  headless.close();
  std::string out;
  EXPECT_EQ(run(kTool.string() + " run --poses " + (tmp.path / "nohead.csv").string() + " --out " +
                    (tmp.path / "events.jsonl").string(),
                out),
            0)
      << out;
  EXPECT_NE(out.find("has no row of a body named head"), std::string::npos) << out;
}
