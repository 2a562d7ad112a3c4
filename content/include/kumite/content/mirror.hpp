#pragma once
// Left/right mirroring of clips: the mirrored clip is the reflection of the original across
// the actor's sagittal plane (the plane normal to the skeleton's lateral axis through the
// origin), with left and right joints swapped. A left front kick becomes a right front kick,
// so mirroring doubles the database. Exact: the mirrored clip's joint positions are the
// reflected original positions of the partner joints (the skeleton's offsets are reflected
// and swapped too, so asymmetric skeletons stay exact).
#include <vector>

#include "kumite/content/skeleton.hpp"

namespace kumite::content {

/// The coordinate axis (0 = X, 1 = Y, 2 = Z) nearest the right -> left hip (or shoulder)
/// direction at rest. Needs Skeleton::canonical.
int lateral_axis(const Skeleton& skeleton);

/// Partner joint index for every joint (itself for centre joints).
std::vector<int> mirror_map(const Skeleton& skeleton);

/// The mirrored clip, named `<name>_mirror`. Needs Skeleton::canonical.
Clip mirror_clip(const Clip& clip);

}  // namespace kumite::content
