// libFuzzer target: a session's states.bin (FrameStatesReader) and a render node's STATE
// (FrameStateDecoder, the master's console record among them). The input is a sequence of
// records' contents, each `u32 bytes` then the bytes (what a frame or skeleton record holds
// before it is packed); the fuzzer packs each into a whole record (zlib, length, FNV-1a 64)
// behind the file's first line, so that the mutations reach the decoding of the contents
// rather than stop at a checksum. Any input reads to its end or stops at a record with
// problem() set, naming the file; the same records as a STATE decode or say why in words, and
// a console that does not read is said by console_problem(): never a crash, a hang or an
// exception.
#include <unistd.h>
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "kumite/app/frame_states.hpp"
#include "kumite/common/checksum.hpp"
#include "kumite/common/error.hpp"

namespace {

void put32(std::string& s, std::uint32_t v) {
  char b[4];
  std::memcpy(b, &v, 4);
  s.append(b, 4);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("kumite_fuzz_states_" + std::to_string(::getpid()) + ".bin");
  std::string out(kumite::app::kFrameStatesHeader);
  std::string_view in(reinterpret_cast<const char*>(data), size);
  while (in.size() >= 4) {
    std::uint32_t n = 0;
    std::memcpy(&n, in.data(), 4);
    in.remove_prefix(4);
    const std::string_view raw = in.substr(0, std::min<std::size_t>(n, in.size()));
    in.remove_prefix(raw.size());
    uLongf packed = compressBound(static_cast<uLong>(raw.size()));
    std::string z(packed, '\0');
    if (compress2(reinterpret_cast<Bytef*>(z.data()), &packed, reinterpret_cast<const Bytef*>(raw.data()),
                  static_cast<uLong>(raw.size()), 1) != Z_OK)
      return 0;
    z.resize(packed);
    std::string payload;
    put32(payload, static_cast<std::uint32_t>(raw.size()));
    payload += z;
    put32(out, 0x3154534B);
    put32(out, static_cast<std::uint32_t>(payload.size()));
    const std::uint64_t sum = kumite::fnv1a64(payload);
    out.append(reinterpret_cast<const char*>(&sum), 8);
    out += payload;
  }
  if (!in.empty()) out.append(in);  // a cut record at the end
  {
    static kumite::app::FrameStateDecoder decoder;  // its skeletons kept from input to input, as a node's
    kumite::app::FrameData f;
    kumite::app::ConsoleState console;
    const std::string_view records = std::string_view(out).substr(kumite::app::kFrameStatesHeader.size());
    if (decoder.decode(records, f, &console)) {
      if (decoder.has_console() && console.frame_events.size() != f.events.size()) std::abort();
      if (decoder.has_console() && !decoder.console_problem().empty()) std::abort();
      if (decoder.has_console() && console.planner.size() > (64u << 10)) std::abort();  // a string's bound
    } else if (decoder.problem().empty()) {
      std::abort();
    }
  }
  std::ofstream(file, std::ios::binary | std::ios::trunc) << out;
  try {
    kumite::app::FrameStatesReader reader(file);
    kumite::app::FrameData f;
    while (reader.next(f)) {
    }
    if (!reader.problem().empty() && reader.problem().find(file.string()) == std::string::npos) std::abort();
  } catch (const kumite::Error&) {
    std::abort();  // the header is always right here: nothing to throw for
  }
  return 0;
}
