// TEMPORARY until branch content-fighter is merged: the content module does not implement
// the Fighter facade yet, so the installation runs without a fighter and says so. Deleted
// at the merge.
#include "kumite/common/error.hpp"
#include "kumite/content/fighter.hpp"

namespace kumite::content {
std::unique_ptr<Fighter> Fighter::create(const FighterConfig&) {
  throw Error("content", "missing", "the Fighter is not implemented in this build (content-fighter not merged)");
}
std::string_view to_string(FighterState s) {
  switch (s) {
    case FighterState::resting: return "resting";
    case FighterState::following: return "following";
    case FighterState::striking: return "striking";
    case FighterState::recovering: return "recovering";
  }
  return "?";
}
}  // namespace kumite::content
