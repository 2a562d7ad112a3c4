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

template <std::size_t N>
bool starts_with(const std::vector<unsigned char>& b, const std::array<unsigned char, N>& a) {
  return b.size() >= N && std::equal(a.begin(), a.end(), b.begin());
}
template <std::size_t N>
bool ends_with(const std::vector<unsigned char>& b, const std::array<unsigned char, N>& a) {
  return b.size() >= N && std::equal(a.begin(), a.end(), b.end() - static_cast<std::ptrdiff_t>(N));
}
}  // namespace

std::vector<unsigned char> read_file_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) throw Error("io", "open", path.string() + ": cannot open");
  const std::streamoff size = in.tellg();
  std::vector<unsigned char> bytes(static_cast<std::size_t>(std::max<std::streamoff>(0, size)));
  in.seekg(0);
  if (size < 0 || !in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size())))
    throw Error("io", "read", path.string() + ": cannot read");
  return bytes;
}

std::string incomplete_image(const std::vector<unsigned char>& bytes) {
  if (bytes.empty()) return "empty file";
  if (starts_with(bytes, kPngSignature)) return ends_with(bytes, kPngEnd) ? "" : "PNG cut short (no IEND chunk at its end)";
  return "";
}

}  // namespace kumite
