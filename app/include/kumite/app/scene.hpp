#pragma once
// What a frame draws, computed on the CPU once per frame (no GL here): per wall and eye the
// view and projection, and the fighter as a list of lit primitives (capsules = a cylinder per
// bone + a sphere per joint; the strike target as a small sphere). The GL renderer only walks
// these lists, so the per-frame CPU cost is measurable on its own (bench/app).
#include <array>
#include <optional>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "kumite/app/projection.hpp"

namespace kumite::content {
struct FighterFrame;
}

namespace kumite::app {

enum class Mesh : unsigned char { sphere, cylinder };

/// One lit primitive: the unit mesh (sphere radius 1 at the origin; cylinder radius 1 along
/// +Y from y = 0 to 1) placed by `model` (room frame, metres).
struct DrawItem {
  glm::mat4 model{1.0f};
  glm::vec3 colour{1.0f};  ///< linear RGB 0..1
  Mesh mesh = Mesh::sphere;
};

/// The views of every wall for both eyes. Index [wall][0 = left, 1 = right].
using WallViews = std::vector<std::array<EyeView, 2>>;

/// Fills `views` (resized to walls.size()) for `eyes`. A view that comes out invalid (an eye
/// on or behind a wall's plane) keeps its previous value: walls keep drawing from the last
/// good eye positions. Returns how many views were kept that way; `kept_walls`, when it has
/// one entry per wall, gets 1 for each wall with a view kept, 0 for the others.
int plan_views(std::span<const WallFrame> walls, const Eyes& eyes, double near_m, double far_m,
               WallViews& views, std::span<std::uint8_t> kept_walls = {});

/// The colour of character `index` (0-based), cycling through a palette of six saturated
/// colours that stand out on the dark room (the demo's five characters each have their own).
glm::vec3 character_colour(int index);
/// The strike target's colour.
inline constexpr glm::vec3 kTargetColour{0.95f, 0.1f, 0.1f};

/// Appends the fighter as capsules (cylinder per bone, sphere per joint) and, during a
/// strike, the target sphere. `items` is cleared first; no allocation once it has capacity.
void plan_fighter(const content::FighterFrame& fighter, glm::vec3 colour,
                  std::vector<DrawItem>& items);

/// plan_fighter's capsules of character `character` (its colour or its joints' darker one):
/// told from the wall glow by colour, as DrawItem carries no tag (its fields are the recorded
/// frame's). The skinned body replaces exactly these.
bool is_fighter_item(const DrawItem& item, int character);
/// plan_fighter's strike-target sphere: a debug mark (drawn only with [render] debug_marks).
bool is_target_item(const DrawItem& item);

/// The most items plan_fighter appends for a skeleton of `joints` joints (a sphere per
/// joint, a bone and a rounded end per non-root joint, the target).
constexpr std::size_t most_fighter_items(std::size_t joints) { return 3 * joints + 1; }
/// The most bars plan_wall_glow appends (1.6 m at 0.2 m: at most 9 each way).
constexpr std::size_t kMostWallGlowItems = 18;

/// The boundary glow of a wall the visitor is close to: a grid of thin bars (0.2 m apart)
/// 1 cm in front of `wall`, over a 1.6 m square round `near` (the head) projected onto it and
/// kept within the wall; amber to red as `strength` (0..1) grows. Appended to `items`.
void plan_wall_glow(const WallFrame& wall, const glm::dvec3& near, double strength, std::vector<DrawItem>& items);
/// The glow's colour at `strength` 0..1 (amber to red).
glm::vec3 glow_colour(double strength);

/// The room's static lines (wall outlines, floor grid continuing into the virtual room):
/// pairs of points (m, room frame) with a colour each.
struct LineVertex {
  glm::vec3 position;
  glm::vec3 colour;
};
std::vector<LineVertex> room_lines(std::span<const WallFrame> walls);

}  // namespace kumite::app
