#pragma once
// The learned strike recogniser (Touché, Dehesa et al., CHI 2020): per 60 Hz loop and limb, a
// small 1-D dilated convolutional network reads the limb's last 16 loops (head-relative
// position and velocity from the same Frontend as the DTW recogniser: exponentially smoothed,
// in head heights, left limbs mirrored) and outputs the strike class (the actions its
// training data had for that limb kind, plus "none") and the strike's progress 0..1 (0 at the
// onset, 1 at full extension). Trained offline (recognition/train/train_touche.py, Debian's
// torch); here only inference: a few hundred lines, no torch at runtime.
//
// Network (per limb kind): conv1 (6 -> H, kernel 4, dilation 1) ReLU, conv2 (H -> H, kernel 4,
// dilation 4) ReLU, a 1x1 output layer -> class logits (softmax) + progress (sigmoid). The
// receptive field is the 16-loop window. Inputs are normalised by the training set's mean/std.
//
// Events: `begin` when a strike class's probability reaches begin_probability (0.5: the class
// is then the most likely one) with predicted progress >= begin_progress, for confirm_frames
// loops in a row, while the limb moves faster than min_speed; `switch` when another
// strike class becomes the most likely; `end` when "none" has been the most likely for
// end_frames loops; `cancel` when the limb's poses stop mid-strike or the stream ends.
#include <array>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "kumite/recognition/recognition.hpp"

namespace kumite::recognition {

inline constexpr int kLearnedInputs = 6;   ///< position (3), velocity (3)
inline constexpr int kLearnedWindow = 16;  ///< loops the network sees
using LearnedInput = std::array<float, kLearnedInputs>;

/// One network (one limb kind). Tensors in torch's layouts, row-major.
struct LearnedNet {
  LimbKind kind = LimbKind::hand;
  std::vector<std::string> classes;  ///< classes[0] = "none"
  int hidden = 100;
  std::vector<float> mean, std;      ///< [6]: input normalisation
  std::vector<float> conv1_weight;   ///< [hidden][6][4]
  std::vector<float> conv1_bias;     ///< [hidden]
  std::vector<float> conv2_weight;   ///< [hidden][hidden][4]
  std::vector<float> conv2_bias;     ///< [hidden]
  std::vector<float> out_weight;     ///< [classes + 1][hidden]
  std::vector<float> out_bias;       ///< [classes + 1]
  std::vector<float> impact;         ///< [classes][3]: mean input position at full extension
};

struct LearnedSettings {
  FrontendSettings frontend;
  double begin_probability = 0.5;  ///< a strike class this likely (and the most likely) begins
  double begin_progress = 0.0;     ///< ... once its predicted progress is at least this
  int end_frames = 3;              ///< "none" the most likely for this many loops: end
  int confirm_frames = 1;          ///< the same strike class for this many loops before begin
  double min_speed = 0;            ///< m/s: begin only while the limb moves this fast (relative to the head)
};

struct LearnedModel {
  static constexpr int kVersion = 1;
  LearnedSettings settings;
  std::vector<LearnedNet> nets;  ///< one per limb kind (hand, foot), at most
  std::string note;              ///< provenance and licence, one line
  const LearnedNet* net(LimbKind k) const {
    for (const auto& n : nets)
      if (n.kind == k) return &n;
    return nullptr;
  }
};

/// Model file (.klearn): text; "kumite-learned-model <version>", "checksum fnv1a64 <hex>" of
/// every byte after that line, "note", "setting <name> <value>" lines, per net a line
/// "net <hand|foot> classes <n> <names...> input 6 hidden <H> kernel1 4 dilation1 1 kernel2 4
/// dilation2 4" and its tensors "tensor <name> <dims...> <base64 little-endian float32>",
/// then "end". Written by train_touche.py. Another version, a bad checksum, a cut file,
/// wrong shapes, non-finite or out-of-range numbers: kumite::Error "file:line: key: message".
LearnedModel parse_learned_model(std::string_view text, std::string_view source);
LearnedModel read_learned_model(const std::filesystem::path& path);

struct LearnedOutput {
  std::vector<float> probabilities;  ///< per class (softmax)
  float progress = 0;                ///< 0..1
};
/// The network on one window (window[0] the oldest loop, raw inputs). `scratch` is reused.
void learned_infer(const LearnedNet& net, std::span<const LearnedInput, kLearnedWindow> window, LearnedOutput& out,
                   std::vector<float>& scratch);

/// The learned recogniser: the same Frontend and event stream as Recogniser.
class LearnedRecogniser {
 public:
  explicit LearnedRecogniser(LearnedModel model);
  void push(const PoseSample& s, std::vector<Event>& out);
  /// Every sample up to t was pushed: the loops up to t now (as Recogniser::end_of_set).
  void end_of_set(Timestamp t, std::vector<Event>& out);
  void finish(Timestamp t, std::vector<Event>& out);
  const LearnedModel& model() const { return model_; }
  long loops() const { return loops_; }
  void set_timing(bool on) { timing_ = on; }
  const std::vector<double>& loop_times() const { return loop_times_; }

 private:
  struct LimbState {
    std::array<LearnedInput, kLearnedWindow> history{};
    int filled = 0;          ///< valid loops in history (capped at the window)
    bool active = false;
    int current = 0;         ///< class index of the active strike
    int none_run = 0;
    int candidate = 0, candidate_run = 0;  ///< the strike class seen in a row before begin
    double progress = 0, confidence = 0;
    Vec3 impact{0, 0, 0};
  };
  void loop(const Frame& f, std::vector<Event>& out);
  void run_frames(std::vector<Event>& out);  ///< loops over frames_
  Event event(const Frame& f, int limb, EventType type, const LearnedNet& net, int cls);
  Event cancel_event(int limb, const LimbState& st, Timestamp t) const;

  LearnedModel model_;
  Frontend frontend_;
  std::array<LimbState, kLimbCount> limbs_{};
  std::vector<Frame> frames_;
  std::vector<float> scratch_;
  LearnedOutput output_;
  std::array<LearnedInput, kLearnedWindow> window_{};
  Timestamp now_ = 0;
  long loops_ = 0;
  bool timing_ = false;
  std::vector<double> loop_times_;
};

}  // namespace kumite::recognition
