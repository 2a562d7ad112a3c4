#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "kumite/common/atomic_file.hpp"
#include "kumite/common/text.hpp"
#include "kumite/common/error.hpp"
#include "kumite/common/image_file.hpp"
#include "kumite/common/latest.hpp"
#include "kumite/common/wire.hpp"

namespace fs = std::filesystem;
using namespace kumite;

namespace {
fs::path fresh_dir(const std::string& name) {
  fs::path d = fs::temp_directory_path() / ("kumite-test-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}
std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST(Error, FormatsFileLineKey) {
  EXPECT_EQ(format_location("a.toml", 12, "walls.front", "bad"), "a.toml:12: walls.front: bad");
  EXPECT_EQ(format_location("a.toml", 0, "", "missing"), "a.toml: missing");
  Error e = file_error("config", "missing_key", "x.toml", 3, "k", "is required");
  EXPECT_EQ(e.component(), "config");
  EXPECT_EQ(e.code(), "missing_key");
  EXPECT_STREQ(e.what(), "x.toml:3: k: is required");
}

TEST(AtomicFile, WritesAndReplaces) {
  fs::path d = fresh_dir("atomic");
  write_file_atomically(d / "a.txt", std::string_view("one"));
  EXPECT_EQ(slurp(d / "a.txt"), "one");
  write_file_atomically(d / "a.txt", std::string_view("two"));
  EXPECT_EQ(slurp(d / "a.txt"), "two");
  // Only the file itself is left: no temporaries.
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 1);
}

TEST(AtomicFile, FailedWriterLeavesOldContent) {
  fs::path d = fresh_dir("atomic-fail");
  write_file_atomically(d / "a.txt", std::string_view("good"));
  EXPECT_THROW(write_file_atomically(d / "a.txt",
                                     [](std::ostream& out) {
                                       out << "half";
                                       throw std::runtime_error("boom");
                                     }),
               std::runtime_error);
  EXPECT_EQ(slurp(d / "a.txt"), "good");
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 1);
}

TEST(AtomicFile, UnwritableDirectoryNamesThePath) {
  try {
    write_file_atomically("/nonexistent-dir/x.txt", std::string_view("x"));
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.txt"), std::string::npos);
  }
}

TEST(ImageFile, AWholePngPassesACutOneIsNamed) {
  // The smallest whole PNG (1x1 grey, written by hand: signature, IHDR, IDAT, IEND).
  const std::vector<unsigned char> png = {
      0x89, 'P',  'N',  'G',  '\r', '\n', 0x1a, '\n', 0,    0,    0,    13,   'I',  'H',  'D',  'R',  0,
      0,    0,    1,    0,    0,    0,    1,    8,    0,    0,    0,    0,    0x3a, 0x7e, 0x9b, 0x55, 0,
      0,    0,    10,   'I',  'D',  'A',  'T',  0x78, 0x9c, 0x63, 0x60, 0,    0,    0,    2,    0,    1,
      0x48, 0xaf, 0xa4, 0x71, 0,    0,    0,    0,    'I',  'E',  'N',  'D',  0xae, 0x42, 0x60, 0x82};
  EXPECT_EQ(incomplete_image(png), "");
  const std::vector<unsigned char> cut(png.begin(), png.end() - 5);
  EXPECT_EQ(incomplete_image(cut), "PNG cut short (no IEND chunk at its end)");
  EXPECT_EQ(incomplete_image({}), "empty file");
  EXPECT_EQ(incomplete_image({'n', 'o', 't'}), "");  // not a PNG: the decoder decides
  std::vector<unsigned char> padded = png;
  padded.insert(padded.end(), 100, 0);  // bytes after IEND, as some writers leave
  EXPECT_EQ(incomplete_image(padded), "");

  const fs::path d = fresh_dir("image");
  write_file_atomically(d / "a.png", std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  EXPECT_EQ(read_file_bytes(d / "a.png"), png);
  try {
    (void)read_file_bytes(d / "missing.png");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.png: cannot open"), std::string::npos) << e.what();
  }
  try {
    (void)read_file_bytes(d);  // a folder where an image was expected
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(": not a file"), std::string::npos) << e.what();
  }
}

TEST(AtomicFile, KeepsPreviousVersion) {
  fs::path d = fresh_dir("backup");
  EXPECT_TRUE(keep_previous_version(d / "cal.yaml").empty());
  write_file_atomically(d / "cal.yaml", std::string_view("v1"));
  fs::path b1 = keep_previous_version(d / "cal.yaml");
  fs::path b2 = keep_previous_version(d / "cal.yaml");
  EXPECT_NE(b1, b2);
  EXPECT_EQ(slurp(b1), "v1");
  EXPECT_EQ(slurp(b2), "v1");
}

// A power cut must find the old file or the new one, whole: the temporary is synced to disk
// before the rename and the folder after it (without the syncs the rename can reach the disk
// before the data: an empty or cut file under the final name).
TEST(AtomicFile, SyncsTheFileBeforeTheRenameAndTheFolderAfter) {
  fs::path d = fresh_dir("durable");
  std::vector<std::string> ops;
  observe_durable_writes([&](const std::string& op) { ops.push_back(op); });
  write_file_atomically(d / "cal.yaml", std::string_view("v1"));
  const fs::path backup = keep_previous_version(d / "cal.yaml");
  observe_durable_writes(nullptr);
  ASSERT_EQ(ops.size(), 6u) << ::testing::PrintToString(ops);
  for (int k : {0, 3}) {
    const fs::path target = k == 0 ? d / "cal.yaml" : backup;
    EXPECT_EQ(ops[static_cast<std::size_t>(k)].rfind("sync " + d.string() + "/.", 0), 0u) << ops[static_cast<std::size_t>(k)];
    const std::string tmp = ops[static_cast<std::size_t>(k)].substr(5);
    EXPECT_EQ(ops[static_cast<std::size_t>(k) + 1], "rename " + tmp + " -> " + target.string());
    EXPECT_EQ(ops[static_cast<std::size_t>(k) + 2], "sync " + d.string());
  }
  EXPECT_EQ(slurp(d / "cal.yaml"), "v1");
  EXPECT_EQ(slurp(backup), "v1");
  EXPECT_THROW(sync_path(d / "missing"), Error);
}

TEST(Text, AByteOrderMarkIsDropped) {
  EXPECT_EQ(without_utf8_bom("\xEF\xBB\xBFtime_s,order\n"), "time_s,order\n");
  EXPECT_EQ(without_utf8_bom("time_s,order"), "time_s,order");
  EXPECT_EQ(without_utf8_bom("\xEF\xBB"), "\xEF\xBB");
  EXPECT_EQ(without_utf8_bom(""), "");
}

TEST(Orders, RoundTripText) {
  for (const char* s : {"punch_left", "punch_right", "kick_left", "kick_right", "pause", "resume",
                        "recentre", "character 3"}) {
    auto o = parse_order(s, 1.5);
    ASSERT_TRUE(o) << s;
    EXPECT_EQ(to_string(*o), s);
    EXPECT_DOUBLE_EQ(o->time, 1.5);
  }
  EXPECT_EQ(parse_order("character_2")->character, 1);
  EXPECT_FALSE(parse_order("punch"));
  EXPECT_FALSE(parse_order("character 0"));
  EXPECT_FALSE(parse_order("character x"));
}

TEST(LatestValue, EmptyThenNewest) {
  LatestValue<BodyPose> slot;
  EXPECT_FALSE(slot.read());
  BodyPose p;
  p.frame = 7;
  p.position = {1, 2, 3};
  slot.publish(p);
  auto r = slot.read();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->frame, 7u);
  EXPECT_EQ(r->position[2], 3);
  EXPECT_EQ(slot.version(), 1u);
}

TEST(LatestValue, ReaderNeverSeesATornValue) {
  // Writer publishes poses whose fields all equal the frame number; a torn read would mix two.
  // It keeps publishing until the reader has read often enough (on a loaded machine the reader
  // may not run at all during 200000 publishes, which made this test fail without a bug).
  LatestValue<BodyPose> slot;
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> reads{0}, published{0};
  constexpr std::uint64_t kMinPublishes = 200000, kMinReads = 1000;
  std::thread writer([&] {
    std::uint64_t i = 0;
    while (i < kMinPublishes || reads.load(std::memory_order_relaxed) < kMinReads) {
      ++i;
      BodyPose p;
      p.frame = i;
      p.timestamp = double(i);
      p.position = {double(i), double(i), double(i)};
      slot.publish(p);
    }
    published = i;
    done = true;
  });
  std::uint64_t last = 0;
  while (!done) {
    if (auto r = slot.read()) {
      ASSERT_EQ(r->timestamp, double(r->frame));
      ASSERT_EQ(r->position[0], double(r->frame));
      ASSERT_EQ(r->position[2], double(r->frame));
      ASSERT_GE(r->frame, last);  // never goes back in time
      last = r->frame;
      reads.fetch_add(1, std::memory_order_relaxed);
    }
  }
  writer.join();
  EXPECT_GE(reads.load(), kMinReads);
  EXPECT_EQ(slot.read()->frame, published.load());
}
