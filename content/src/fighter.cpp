// The Fighter facade: Behaviour (single-threaded) + a retrieval worker thread. The update
// never waits for the worker: requests go into a one-slot mailbox, results are taken with
// try_lock, and the behaviour keeps animating rest / blends meanwhile.
#include "kumite/content/fighter.hpp"

#include <condition_variable>
#include <mutex>
#include <thread>

#include "kumite/common/error.hpp"
#include "kumite/content/behaviour.hpp"

namespace kumite::content {

std::string_view to_string(FighterState s) {
  switch (s) {
    case FighterState::resting: return "resting";
    case FighterState::following: return "following";
    case FighterState::striking: return "striking";
    case FighterState::recovering: return "recovering";
  }
  return "?";
}

std::string_view to_string(FighterEvent::Kind k) {
  switch (k) {
    case FighterEvent::Kind::order_accepted: return "order_accepted";
    case FighterEvent::Kind::order_ignored: return "order_ignored";
    case FighterEvent::Kind::hit: return "hit";
    case FighterEvent::Kind::dodged: return "dodged";
    case FighterEvent::Kind::miss: return "miss";
    case FighterEvent::Kind::character_changed: return "character_changed";
    case FighterEvent::Kind::warning: return "warning";
  }
  return "?";
}

namespace {

class RetrievalWorker {
 public:
  explicit RetrievalWorker(std::shared_ptr<const StrikePlanner> planner)
      : planner_(std::move(planner)), thread_([this] { run(); }) {}
  ~RetrievalWorker() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_one();
    thread_.join();
  }
  // Called from the update thread: a short critical section (copy a request), no waiting on
  // the search itself.
  void submit(const StrikeRequest& r) {
    {
      std::lock_guard lock(mutex_);
      request_ = r;
    }
    cv_.notify_one();
  }
  std::optional<StrikePlan> poll() {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || !result_) return std::nullopt;
    auto r = result_;
    result_.reset();
    return r;
  }

 private:
  void run() {
    for (;;) {
      StrikeRequest r;
      {
        std::unique_lock lock(mutex_);
        cv_.wait(lock, [&] { return stop_ || request_.has_value(); });
        if (stop_) return;
        r = *request_;
        request_.reset();
      }
      StrikePlan p = planner_->plan(r);
      std::lock_guard lock(mutex_);
      result_ = p;
    }
  }
  std::shared_ptr<const StrikePlanner> planner_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<StrikeRequest> request_;
  std::optional<StrikePlan> result_;
  bool stop_ = false;
  std::thread thread_;
};

class FighterImpl final : public Fighter {
 public:
  FighterImpl(std::shared_ptr<const Database> db, std::vector<Rig> rigs, const FighterConfig& config)
      : behaviour_(db, std::move(rigs), config),
        worker_(std::make_unique<RetrievalWorker>(std::make_shared<StrikePlanner>(db))) {
    behaviour_.set_planner([this](const StrikeRequest& r) { worker_->submit(r); },
                           [this] { return worker_->poll(); });
  }
  void order(const Order& order) override { behaviour_.order(order); }
  void update(Timestamp now, double dt, const Eigen::Vector3d& head) override { behaviour_.update(now, dt, head); }
  FighterFrame frame() const override { return behaviour_.frame(); }
  std::vector<FighterEvent> take_events() override { return behaviour_.take_events(); }
  int character_count() const override { return behaviour_.character_count(); }
  std::string character_name(int index) const override {
    if (index < 0 || index >= character_count()) return {};
    return behaviour_.character(index).name;
  }

 private:
  Behaviour behaviour_;
  std::unique_ptr<RetrievalWorker> worker_;  // declared last: joins first on destruction
};

}  // namespace

std::unique_ptr<Fighter> Fighter::create(const FighterConfig& config) {
  auto db = std::make_shared<const Database>(load_database(config.database));
  auto rigs = load_character_rigs(config);
  if (rigs.empty()) throw Error("fighter", "config", "fighter: no characters configured");
  return std::make_unique<FighterImpl>(std::move(db), std::move(rigs), config);
}

}  // namespace kumite::content
