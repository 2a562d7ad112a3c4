#pragma once
// Image files read from disk (recordings, calibration photos): whole, or why not.
//
// libpng and libjpeg, under OpenCV's decoders, print their own raw line on stderr when a
// file ends early ("libpng error: Read Error"), before OpenCV returns an empty image and the
// caller's one clear line names the file. A PNG cut short (a copy or a write that did not
// finish, the usual damage) is therefore found here first, from its bytes: a whole PNG ends
// with its IEND chunk (found in its last 4 kB: some writers append bytes after it); a whole
// JPEG with its end-of-image marker (libjpeg would only warn and return the image with its
// missing part grey: "board not found" instead of "cut short"). Damage inside a whole file,
// and other formats, are left to the decoder.
#include <filesystem>
#include <string>
#include <vector>

namespace kumite {

/// The file's bytes. Throws kumite::Error("io", ...) naming the path when it is missing, not
/// a regular file (a folder) or cannot be read.
std::vector<unsigned char> read_file_bytes(const std::filesystem::path& path);

/// Why `bytes` cannot be a whole image file, as a few words for a message: an empty file, a
/// PNG without its IEND chunk in its last 4 kB, a JPEG without its end-of-image marker (FF D9)
/// in its last 4 kB (libjpeg would decode it with its missing part grey). "" otherwise (the
/// decoder decides).
std::string incomplete_image(const std::vector<unsigned char>& bytes);

}  // namespace kumite
