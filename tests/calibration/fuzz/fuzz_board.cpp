// libFuzzer target: the calibration board reader (parse_board, which validates) turns any
// input into a Board or a kumite::Error, never crashes, hangs or exhausts memory; a board it
// accepts is written back with board_to_toml and reads back to the same text.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "kumite/calibration/board.hpp"
#include "kumite/common/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  kumite::calibration::Board board;
  try {
    board = kumite::calibration::parse_board(text, "fuzz/board.toml");
  } catch (const kumite::Error&) {
    return 0;
  }
  const std::string out = kumite::calibration::board_to_toml(board);
  try {
    const auto back = kumite::calibration::parse_board(out, "fuzz/board-out.toml");
    if (kumite::calibration::board_to_toml(back) != out) std::abort();
  } catch (const kumite::Error&) {
    std::abort();  // the writer wrote what the reader refuses
  }
  return 0;
}
