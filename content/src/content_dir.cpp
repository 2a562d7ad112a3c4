// default_content_dir() on its own: the one content source compiled with this checkout's
// absolute path (KUMITE_CONTENT_SOURCE_DIR, content/CMakeLists.txt), so that every other
// content source compiles to the same object in any clone and ccache serves it (CI clones
// into a folder of its own).
#include <cstdlib>

#include "kumite/content/canonical.hpp"

#ifndef KUMITE_CONTENT_SOURCE_DIR
#define KUMITE_CONTENT_SOURCE_DIR "content"
#endif

namespace kumite::content {

std::filesystem::path default_content_dir() {
  if (const char* env = std::getenv("KUMITE_CONTENT_DIR"); env != nullptr && *env != 0) return env;
  return KUMITE_CONTENT_SOURCE_DIR;
}

}  // namespace kumite::content
