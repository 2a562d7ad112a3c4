#include "kumite/common/image_file.hpp"

#include <algorithm>
#include <array>
#include <fstream>

#include "kumite/common/error.hpp"

namespace kumite {

namespace {
constexpr std::array<unsigned char, 8> kPngSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
/// The IEND chunk, as every whole PNG ends: length 0, type "IEND", its CRC.
constexpr std::array<unsigned char, 12> kPngEnd = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
/// bytes: how far from the end the IEND chunk is looked for.
constexpr std::size_t kPngTail = 4096;
/// JPEG: SOI at the start, EOI (FF D9) ends a whole file (found in its last 4 kB: some cameras
/// pad after it). libjpeg decodes a JPEG cut short with only a warning, its missing part grey.
constexpr std::array<unsigned char, 2> kJpegStart = {0xff, 0xd8};
constexpr std::array<unsigned char, 2> kJpegEnd = {0xff, 0xd9};

template <std::size_t N>
bool starts_with(const std::vector<unsigned char>& b, const std::array<unsigned char, N>& a) {
  return b.size() >= N && std::equal(a.begin(), a.end(), b.begin());
}
}  // namespace

std::vector<unsigned char> read_file_bytes(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error("io", "open", path.string() + (std::filesystem::exists(path, ec) ? ": not a file" : ": cannot open"));
  const auto size = std::filesystem::file_size(path, ec);
  std::ifstream in(path, std::ios::binary);
  if (ec || !in) throw Error("io", "open", path.string() + ": cannot open");
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
    throw Error("io", "read", path.string() + ": cannot read");
  return bytes;
}

std::string incomplete_image(const std::vector<unsigned char>& bytes) {
  if (bytes.empty()) return "empty file";
  if (starts_with(bytes, kPngSignature)) {
    // IEND ends a whole PNG; some writers append bytes after it (libpng ignores them).
    const std::size_t tail = std::min<std::size_t>(bytes.size(), kPngTail);
    const auto from = bytes.end() - static_cast<std::ptrdiff_t>(tail);
    return std::search(from, bytes.end(), kPngEnd.begin(), kPngEnd.end()) != bytes.end()
               ? ""
               : "PNG cut short (no IEND chunk at its end)";
  }
  if (starts_with(bytes, kJpegStart)) {
    const std::size_t tail = std::min<std::size_t>(bytes.size() - kJpegStart.size(), kPngTail);
    const auto from = bytes.end() - static_cast<std::ptrdiff_t>(tail);
    return std::search(from, bytes.end(), kJpegEnd.begin(), kJpegEnd.end()) != bytes.end()
               ? ""
               : "JPEG cut short (no end-of-image marker at its end)";
  }
  return "";
}

}  // namespace kumite
