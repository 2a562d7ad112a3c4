// libFuzzer target: the BVH reader must turn any input into a Clip or a kumite::Error, never
// crash, hang or exhaust memory. Parsed clips are written back and re-read (the writer must
// accept anything the reader produced).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "kumite/common/error.hpp"
#include "kumite/content/bvh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const kumite::content::Clip clip = kumite::content::parse_bvh(text, "fuzz.bvh");
    if (clip.frame_count <= 50 && clip.skeleton.joint_count() <= 100) {
      (void)kumite::content::parse_bvh(kumite::content::format_bvh(clip), "fuzz-out.bvh");
    }
  } catch (const kumite::Error&) {
  }
  return 0;
}
