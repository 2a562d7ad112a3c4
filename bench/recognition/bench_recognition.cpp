// Recognition benchmark (a `bench` command printing JSON): compute per 60 Hz loop (all four
// limbs) of the dual-buffer DTW recogniser and of the learned (Touché) one with the shipped
// models (the learned one's cost does not depend on the motion: one network pass per limb), in CPU time of this
// thread (a shared machine's preemption excluded), pinned to one core, on SYNTHETIC streams:
//   - "strikes_and_walk": a synthetic visitor punching, kicking, walking and standing;
//   - "worst_case": every limb shaking faster than the onset speed without a null signal, so
//     every limb holds a growing buffer (up to 60 frames) re-matched against every template
//     each loop: the most DTW work a loop can do.
// Target (issue 14): <= 0.5 ms per loop.
//
//   build/bin/kumite_recognition_bench [seconds=60] [model=recognition/models/strikes.krec]
//                                      [learned=recognition/models/strikes.klearn]
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "kumite/recognition/learned.hpp"
#include "kumite/recognition/recognition.hpp"
#include "offline.hpp"

using namespace kumite::recognition;
using offline::SynthMove;

namespace {
double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(p * static_cast<double>(v.size() - 1))];
}

template <class Rec, class M>
std::string run(const char* name, const M& m, const std::vector<PoseSample>& samples) {
  Rec r(m);
  r.set_timing(true);
  std::vector<Event> ev;
  for (const auto& s : samples) r.push(s, ev);
  std::vector<double> us;
  for (double t : r.loop_times()) us.push_back(t * 1e6);
  double mean = 0;
  for (double u : us) mean += u;
  mean /= std::max<std::size_t>(1, us.size());
  return fmt::format(R"("{}": {{"loops": {}, "events": {}, "loop_cpu_us": {{"mean": {:.2f}, "p50": {:.2f}, "p99": {:.2f}, "max": {:.2f}}}}})",
                     name, us.size(), ev.size(), mean, pct(us, 0.5), pct(us, 0.99), pct(us, 1.0));
}
}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60;
  const std::filesystem::path model_path =
      argc > 2 ? std::filesystem::path(argv[2]) : std::filesystem::path(KUMITE_SOURCE_DIR) / "recognition/models/strikes.krec";
  const std::filesystem::path learned_path =
      argc > 3 ? std::filesystem::path(argv[3]) : std::filesystem::path(KUMITE_SOURCE_DIR) / "recognition/models/strikes.klearn";
  if (!(seconds > 0 && seconds < 3600)) {
    std::fprintf(stderr, "kumite_recognition_bench: seconds must be in (0, 3600)\n");
    return 1;
  }
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(0, &set);
  const bool pinned = sched_setaffinity(0, sizeof(set), &set) == 0;
  try {
    const Model m = read_model(model_path);
    const LearnedModel lm = read_learned_model(learned_path);
    // SYNTHETIC visitor: punches, kicks, a walk, standing; repeated to `seconds`.
    std::vector<offline::SynthSegment> segs;
    for (double t = 0; t < seconds; t += 8) {
      segs.push_back({SynthMove::straight_punch, Role::right_hand, 1.0, 1.0});
      segs.push_back({SynthMove::straight_punch, Role::left_hand, 1.0, 1.2});
      segs.push_back({SynthMove::front_kick, Role::right_foot, 1.5, 1.0});
      segs.push_back({SynthMove::walk, Role::head, 3.0, 1.0});
      segs.push_back({SynthMove::idle, Role::head, 1.5, 1.0});
    }
    const auto mixed = offline::synthesise(segs, 120, 1.0).samples;
    // SYNTHETIC worst case: every limb circles at 2.5 m/s around its stance point.
    std::vector<PoseSample> shake;
    const Vec3 base[kRoleCount] = {{0, 1.62, 0}, {-0.18, 1.3, -0.25}, {0.18, 1.3, -0.25}, {-0.15, 0.3, 0}, {0.15, 0.3, 0}};
    for (long k = 0; k < static_cast<long>(seconds * 120); ++k) {
      const double t = k / 120.0;
      for (int r = 0; r < kRoleCount; ++r) {
        PoseSample s;
        s.t = t;
        s.role = static_cast<Role>(r);
        s.position = base[r];
        if (r > 0) {
          const double w = 2 * std::numbers::pi * (1.3 + 0.2 * r), a = 2.5 / w;
          s.position[0] += a * std::cos(w * t);
          s.position[1] += a * std::sin(w * t);
          s.position[2] += 0.3 * a * std::sin(0.5 * w * t);
        }
        shake.push_back(s);
      }
    }
    std::printf("{\"what\": \"recognition per-loop compute (all four limbs), SYNTHETIC streams, shipped models\", "
                "\"pinned_to_cpu0\": %s, \"seconds\": %.0f, \"target_loop_us\": 500,\n"
                " \"dtw\": {\"model\": \"%s\",\n  %s,\n  %s},\n"
                " \"learned\": {\"model\": \"%s\",\n  %s,\n  %s}}\n",
                pinned ? "true" : "false", seconds, model_path.string().c_str(),
                run<Recogniser>("strikes_and_walk", m, mixed).c_str(), run<Recogniser>("worst_case", m, shake).c_str(),
                learned_path.string().c_str(), run<LearnedRecogniser>("strikes_and_walk", lm, mixed).c_str(),
                run<LearnedRecogniser>("worst_case", lm, shake).c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
