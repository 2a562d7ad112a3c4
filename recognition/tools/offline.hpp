#pragma once
// The offline side of recognition (not the runtime library): development mocap turned into
// visitor pose streams and labelled strikes, training, the cross-actor evaluation, and
// SYNTHETIC visitors (labelled as such) for tests and benchmarks. Uses content's BVH reader.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "kumite/content/skeleton.hpp"
#include "kumite/recognition/learned.hpp"
#include "kumite/recognition/poses_file.hpp"
#include "kumite/recognition/recognition.hpp"

namespace kumite::recognition::offline {

/// One labelled strike in a recording (0-based frames of the recording, inclusive).
struct Strike {
  std::string name;
  std::string action;  ///< straight_punch | front_kick | side_kick | roundhouse_kick
  Role limb = Role::right_hand;
  int first = 0, hit = 0, last = 0;
};

/// A mocap clip as a visitor's pose stream (room frame: the actor turned to face -Z at the
/// first frame, pelvis over the origin), with what the evaluation needs.
struct Recording {
  std::string name;   ///< "135_04", "HDM_bd_kickLFront1Reps_001_120", "Boxing_Toes", ...
  std::string actor;  ///< "135", "bd", ..., "07", "09", "boxer", "sony"
  std::string source; ///< where it came from and its licence note
  double fps = 120;
  int frames = 0;
  std::vector<PoseSample> samples;  ///< 5 per frame (head, hands, feet), time order
  /// m, room frame: the hit joints (wrists, ankles) per frame: [frame][limb].
  std::vector<std::array<Vec3, kLimbCount>> limb_positions;
  std::vector<Strike> strikes;
  bool negative = false;    ///< holds no strike at all (walks, blocks, turns, idle)
  bool trainable = false;   ///< may be used to train a shipped model (from content/motions)
};

/// A clip as a pose stream. Head = the head joint, hands = wrists, feet = ankles (the joints
/// the annotations measure; real gloves sit ~9 cm further). The head's orientation is the
/// yaw of the shoulder line (mocap heads have no glasses): heading only.
Recording recording_from_clip(const content::Clip& clip);

/// Action kind of an annotated strike, from its clip (the annotations say punch/kick only):
/// 135_04 front, 135_07 roundhouse, 135_11 side kicks; 135_06 / 135_09 lunge punches
/// (oi-zuki, "straight_punch"); HDM05 kickLFront front kicks. "" = unknown.
std::string action_of_clip(const std::string& clip_name, bool hand);
/// "135" for CMU 135_*, "bd".."tr" for HDM05, else the clip name.
std::string actor_of_clip(const std::string& clip_name);

/// Every clip of a motions.toml (shippable data): strikes from its punch/kick annotations;
/// clips with no strike annotation become negatives.
std::vector<Recording> load_motions(const std::filesystem::path& motions_toml);

/// Development-only recordings from ../shared/data/mocap (never shipped, never trained on by
/// the shipped model): the assimp boxer's 8 straights (PROVENANCE windows), the Sony crosses
/// (windows around the listed wrist peaks: -40..+40 frames), CMU 07_05 walk and 09_06 run
/// (negatives). Missing files are skipped.
std::vector<Recording> load_external(const std::filesystem::path& mocap_dir);

/// Frontend frames of a recording.
std::vector<Frame> frontend_frames(const Recording& r, const FrontendSettings& s);

/// Trials of the recordings' strikes (actions "" skipped) and "none" trials of the negative
/// recordings (every movement start of every limb).
std::vector<Trial> trials_of(const std::vector<const Recording*>& recs, const RecogniserSettings& s,
                             const TrainSettings& ts);

/// A model trained on `recs`.
Model train(const std::vector<const Recording*>& recs, const RecogniserSettings& rs,
            const TrainSettings& ts, const std::string& note);

/// The cross-actor evaluation (see recognition/README.md): leave-one-actor-out over the
/// trainable actors, the external recordings tested on a model of all trainable data,
/// false triggers on the negatives. JSON.
nlohmann::json evaluate(const std::vector<Recording>& trainable, const std::vector<Recording>& external,
                        const RecogniserSettings& rs, const TrainSettings& ts);

/// The first frame of a strike's window whose hit-joint speed exceeds 15 % of
/// its peak (the onset that latency is measured from, and the learned recogniser's progress 0).
int onset_frame(const Recording& r, const Strike& s);

// ---- The learned recogniser's training data (Touché) -----------------------------------------

/// Per-limb input of the learned recogniser at one loop: head-relative position (3) and
/// velocity (3) as the frontend gives them (LimbFrame::pos, LimbFrame::vel; left mirrored).
std::array<float, 6> learned_input(const LimbFrame& lf);

/// The training set of `train_touche.py` (JSON): per recording its actor, whether it holds no
/// strike, and per 60 Hz loop and limb the input (6 numbers, null when the limb is not valid)
/// and the label: class index (0 = none; -1 = a strike whose kind is unknown: ignored) and
/// progress (0 at the onset, 1 at the hit; -1 when the class is none). Strike frames run from
/// the onset (onset_frame) to the hit; the retraction after the hit is "none".
nlohmann::json learned_dataset(const std::vector<Recording>& recs, const FrontendSettings& fs);

/// Event settings of the learned models overridden for an evaluation (unset: the model's).
struct LearnedOverrides {
  std::optional<double> begin_probability, begin_progress, min_speed;
  std::optional<int> end_frames, confirm_frames;
};

/// The same cross-actor evaluation of the learned recogniser: the fold models in `dir`
/// (fold-<actor>.klearn, without-<recording>.klearn, all.klearn: train_touche.py --eval-dir).
nlohmann::json evaluate_learned(const std::vector<Recording>& trainable, const std::vector<Recording>& external,
                                const std::filesystem::path& dir, const LearnedOverrides& ov = {});

/// The samples as a tracker at `hz` would deliver them: every role at t0 + k / hz exactly (t0 =
/// the first sample's time), positions linearly interpolated between the two samples around
/// it, orientations normalised-lerped; a role lost at either side is lost there.
std::vector<PoseSample> resample(const std::vector<PoseSample>& samples, double hz);

/// Moves a mocap visitor's samples on the floor (every body alike): with `stay_s` > 0 the head's
/// floor position averaged over a centred window of stay_s seconds is taken out (the visitor
/// stays near one spot while limbs keep their motion but for that slow drift: SYNTHETIC); then
/// the whole is shifted so that the head's mean floor position is `place` (x, z; m).
void place_visitor(std::vector<PoseSample>& samples, std::optional<std::array<double, 2>> place, double stay_s);

// ---- SYNTHETIC visitors (tests and benchmarks only) -----------------------------------------

enum class SynthMove { idle, straight_punch, front_kick, walk };
struct SynthSegment {
  SynthMove move = SynthMove::idle;
  Role limb = Role::right_hand;  ///< for strikes
  double duration_s = 1.0;       ///< whole segment (a strike happens at its start)
  double speed = 1.0;            ///< 1 = nominal (punch 0.15 s out, kick 0.3 s up)
};
struct SynthRecording {
  std::vector<PoseSample> samples;
  std::vector<Strike> strikes;  ///< frames = sample frame index (rate_hz)
};
/// A SYNTHETIC visitor (stature `scale` x 1.75 m) facing -Z doing `segments` one after the
/// other, sampled at `rate_hz`.
SynthRecording synthesise(const std::vector<SynthSegment>& segments, double rate_hz = 120, double scale = 1.0);
/// A model trained on SYNTHETIC punches and front kicks (several speeds and statures).
Model synthetic_model(const RecogniserSettings& rs = {});

}  // namespace kumite::recognition::offline
