#pragma once
// One kind of channel to a worker thread for every job the fighter's behaviour hands off: a
// strike to plan (StrikeRequest -> StrikePlan) and a strike's playback rate to find
// (StrikeRateJob -> StrikeRateResult). The behaviour submits a job on its update and polls for
// the result on a later one; whoever owns the worker (the Fighter) or a synchronous stand-in
// (tools, tests) fills in both ends.
#include <functional>
#include <optional>
#include <utility>

namespace kumite::content {

template <class Job, class Result>
struct WorkerChannel {
  using Submit = std::function<void(const Job&)>;
  /// The result of the job submitted last, once it is there (nullopt: none yet, or none due).
  using Poll = std::function<std::optional<Result>()>;
  Submit submit;
  Poll poll;
};

}  // namespace kumite::content
