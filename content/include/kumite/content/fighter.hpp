#pragma once
// The fighter as the app sees it: one object fed with the tracked head and the supervisor's
// orders, giving a pose to draw each frame. Behaviour, retrieval (on its own worker thread)
// and adaptation live behind this facade. Engine-agnostic: no GL, no cameras.
//
// CONTRACT (agreed between content/ and app/; the content module implements it). Room frame:
// metres, +Y up, floor y = 0, front wall toward -Z. Times: kumite::Timestamp seconds.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/common/time.hpp"
#include "kumite/common/wire.hpp"
#include "kumite/content/event.hpp"
#include "kumite/content/fighter_types.hpp"
#include "kumite/content/planner.hpp"
#include "kumite/content/tunables.hpp"
#include "kumite/recognition/recognition.hpp"  // the visitor's body roles and strike kinds (vocabulary only)

namespace kumite::content {

struct FighterConfig {
  std::filesystem::path database;                  ///< fighter.kdb (kumite-motion build)
  std::vector<std::filesystem::path> characters;   ///< character BVH files, in key order 1..N
  std::vector<std::string> character_names;        ///< shown to the supervisor (same order)
  int initial_character = 0;
  Eigen::Vector3d home{0.0, 0.0, -2.5};  ///< m, room frame: where the fighter rests (floor)
  double strike_distance_m = 0.9;        ///< preferred horizontal distance root -> head
  double min_x_m = -1.4, max_x_m = 1.4;  ///< m, lateral limits of where it may walk
  double min_z_m = -4.0, max_z_m = -1.7; ///< m, depth limits (stays behind the front wall)
  double hit_radius_m = 0.10;            ///< m: the strike reached its frozen target when the hit
                                         ///< point ends this close to it
  /// The visitor's body as tracked at contact: a sphere round the head and a capsule below it
  /// (shoulders to shins). A strike hits when its hit point is inside either (the fist or foot
  /// touches the visitor), whatever the frozen target was: a visitor who ducks or steps away
  /// is missed (dodged).
  double visitor_head_radius_m = 0.12;   ///< m, sphere round the tracked head point
  double visitor_body_radius_m = 0.20;   ///< m, radius of the torso/legs capsule
  double visitor_neck_m = 0.25;          ///< m, head point down to the capsule's top
  double visitor_capsule_bottom_m = 0.25;  ///< m above the floor: the capsule's bottom
  BehaviourTunables behaviour;           ///< [fighter.behaviour] (tunables.hpp)
  RetrievalTunables retrieval;           ///< [fighter.retrieval]
  PlannerTunables planner;               ///< [fighter.planner] (planner.hpp): orders or spar
};


struct StrikeRequest;  // behaviour.hpp
struct StrikePlan;
class StrikePlanner;
struct StrikeRateJob;
struct StrikeRateResult;
class StrikeRateSolver;


struct FighterOptions {
  int retrieval_delay_updates = kRetrievalDelayUpdates;  ///< >= 0 (0: plan applied on the order's update)
  /// Runs a plan on the worker thread instead of planner.plan(request) (tests: a slow planner).
  std::function<StrikePlan(const StrikePlanner& planner, const StrikeRequest& request)> plan;
  /// Runs a rate job on the worker thread instead of solver.solve(job) (tests: a slow solver).
  std::function<StrikeRateResult(StrikeRateSolver& solver, const StrikeRateJob& job)> rate;
  /// Set: a character whose file cannot be read (cut, damaged) is left out of the fighter and
  /// reported here (its index in FighterConfig::characters, the error's line), and the others
  /// fight; the fighter's characters are then the readable ones, in order. Unset: it throws.
  std::function<void(std::size_t character, const std::string& why)> on_unreadable_character;
};

class Fighter {
 public:
  /// One update from plain data: the orders queued in order, keep_away, update(), the frame
  /// and the events taken. The bodies and strikes are the visitor as the sparring decisions
  /// will read it: today's fighter (orders alone) carries them and reads only head_m.
  void step(const FighterInput& in, FighterOutput& out) {
    for (const Order& o : in.orders) order(o);
    keep_away(in.keep_away);
    decide(in);
    update(in.now, in.dt_s, in.head_m);
    out.frame = frame();
    out.events = take_events();
  }

  /// Loads the database and characters. Throws kumite::Error naming the file at fault.
  static std::unique_ptr<Fighter> create(const FighterConfig& config, FighterOptions options = {});
  virtual ~Fighter() = default;

  /// Queue an order (any thread that owns the fighter; not thread-safe by itself).
  virtual void order(const Order& order) = 0;
  /// Visitor safety: while on, the fighter backs off and ignores strike orders with a reason
  /// (Behaviour::keep_away); the app sets it while the visitor is near a wall.
  virtual void keep_away(bool on) = 0;
  /// The sparring planner's decision for this update (spar mode; after the supervisor's orders,
  /// which come first): queues its order, if it gives one, and the distance to keep.
  virtual void decide(const FighterInput& in) = 0;
  /// Mode and tunables of the planner from the next update (a key, a preset from the console).
  virtual void set_planner(const PlannerTunables& tunables) = 0;
  using SparScore = content::SparScore;
  using PlannerStatus = content::PlannerStatus;
  virtual PlannerStatus planner_status() const = 0;
  /// The planner's tunables as they are now (the installation's, or the last set_planner()).
  virtual PlannerTunables planner_tunables() const = 0;
  /// Advance to `now` (dt = seconds since the last update) toward the visitor's head
  /// (room frame). Retrieval runs on a worker thread; its plan is applied exactly
  /// retrieval_delay_updates updates after the order (waiting for the worker only if it is
  /// late), so the frames depend on the inputs alone, not on thread timing.
  virtual void update(Timestamp now, double dt, const Eigen::Vector3d& head) = 0;
  virtual FighterFrame frame() const = 0;
  /// Events since the last call (orders accepted/ignored, hit/miss, warnings).
  virtual std::vector<FighterEvent> take_events() = 0;
  /// The event's line for people (describe(), with this fighter's clips and characters).
  virtual std::string describe(const FighterEvent& event) const = 0;
  virtual int character_count() const = 0;
  virtual std::string character_name(int index) const = 0;
  /// The most joints any of its characters has (what a frame's joints may grow to).
  virtual std::size_t most_joints() const = 0;
  virtual RetrievalTiming retrieval_timing() const = 0;
};

}  // namespace kumite::content
