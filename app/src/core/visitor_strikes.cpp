// The recognition thread between the tracking input and the frame (see visitor_strikes.hpp):
// two boost::lockfree::spsc_queue (fixed room, nothing allocated by push or pop), the thread
// sleeping on an atomic counter the producer bumps (std::atomic::wait / notify_one).
#include "kumite/app/visitor_strikes.hpp"

#include <thread>

#include <boost/lockfree/spsc_queue.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace kumite::app {

namespace {
struct Item {
  enum class Kind : std::uint8_t {
    sample,      ///< a pose sample
    end_of_set,  ///< every sample up to sample.t is in (a frame set is whole)
    restart,     ///< the stream jumps at sample.t: cancel and start afresh
  };
  recognition::PoseSample sample;
  Kind kind = Kind::sample;
};
constexpr std::size_t kSamples = 4096;  // ~14 s of five bodies at 60 Hz
constexpr std::size_t kEvents = 256;
}  // namespace

struct StrikeRecognition::Impl {
  explicit Impl(recognition::Model m, std::string w) : model(std::move(m)), what(std::move(w)) {}
  recognition::Model model;
  std::string what;
  boost::lockfree::spsc_queue<Item, boost::lockfree::capacity<kSamples>> in;
  boost::lockfree::spsc_queue<VisitorStrike, boost::lockfree::capacity<kEvents>> out;
  std::atomic<std::uint64_t> pushed{0};  // bumped by the producer: the thread waits on it
  std::atomic<std::uint64_t> done{0};    // items the thread has finished
  std::atomic<std::uint64_t> samples{0}, dropped{0}, events{0}, events_dropped{0};
  std::atomic<bool> stop{false};
  bool inline_on_caller = false;
  std::unique_ptr<recognition::Recogniser> inline_rec;  // inline_on_caller: the caller's
  std::vector<recognition::Event> inline_events;
  std::thread thread;

  void publish(const std::vector<recognition::Event>& events_now) {
    for (const recognition::Event& e : events_now) {
      VisitorStrike s;
      s.t = e.t;
      s.decided_at = inline_on_caller ? e.t : kumite::now();
      s.type = e.type;
      s.limb = e.limb;
      s.action = recognition::action_from_string(e.action);
      s.progress = e.progress;
      s.confidence = e.confidence;
      s.impact = e.impact;
      if (out.push(s))
        events.fetch_add(1, std::memory_order_relaxed);
      else
        events_dropped.fetch_add(1, std::memory_order_relaxed);
    }
  }

  /// One item through the recogniser `rec` (its events published).
  void handle(const Item& it, std::unique_ptr<recognition::Recogniser>& rec, std::vector<recognition::Event>& now_events) {
    now_events.clear();
    switch (it.kind) {
      case Item::Kind::restart:
        rec->finish(it.sample.t, now_events);
        publish(now_events);
        rec = std::make_unique<recognition::Recogniser>(model);
        break;
      case Item::Kind::end_of_set:
        rec->end_of_set(it.sample.t, now_events);
        publish(now_events);
        break;
      case Item::Kind::sample:
        rec->push(it.sample, now_events);
        samples.fetch_add(1, std::memory_order_relaxed);
        publish(now_events);
        break;
    }
  }

  void run() {
    auto rec = std::make_unique<recognition::Recogniser>(model);
    std::vector<recognition::Event> now_events;
    now_events.reserve(16);
    Item it;
    while (true) {
      const std::uint64_t seen = pushed.load(std::memory_order_acquire);
      bool any = false;
      while (in.pop(it)) {
        any = true;
        handle(it, rec, now_events);
        done.fetch_add(1, std::memory_order_release);
        done.notify_all();
      }
      if (stop.load(std::memory_order_acquire)) break;
      if (!any) pushed.wait(seen, std::memory_order_acquire);
    }
  }

  void enqueue(const Item& item) noexcept {
    if (inline_on_caller) {
      handle(item, inline_rec, inline_events);
      pushed.fetch_add(1, std::memory_order_relaxed);
      done.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    if (!in.push(item)) {
      dropped.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    pushed.fetch_add(1, std::memory_order_release);
    pushed.notify_one();
  }
};

StrikeRecognition::StrikeRecognition(recognition::Model model, std::string what, bool inline_on_caller)
    : impl_(std::make_unique<Impl>(std::move(model), std::move(what))) {
  if (inline_on_caller) {
    impl_->inline_on_caller = true;
    impl_->inline_rec = std::make_unique<recognition::Recogniser>(impl_->model);
    impl_->inline_events.reserve(16);
    spdlog::info("recognition: {} ({} templates) on the source's (simulated) clock", impl_->what,
                 impl_->model.templates.size());
    return;
  }
  impl_->thread = std::thread([this] { impl_->run(); });
  spdlog::info("recognition: {} ({} templates) on its own thread", impl_->what, impl_->model.templates.size());
}

StrikeRecognition::~StrikeRecognition() {
  if (!impl_->thread.joinable()) return;
  impl_->stop.store(true, std::memory_order_release);
  impl_->pushed.fetch_add(1, std::memory_order_release);
  impl_->pushed.notify_one();
  impl_->thread.join();
}

void StrikeRecognition::push(const recognition::PoseSample& sample) noexcept {
  impl_->enqueue(Item{sample, Item::Kind::sample});
}

void StrikeRecognition::end_of_set(Timestamp t) noexcept {
  Item it;
  it.sample.t = t;
  it.kind = Item::Kind::end_of_set;
  impl_->enqueue(it);
}

void StrikeRecognition::restart(Timestamp t) noexcept {
  Item it;
  it.sample.t = t;
  it.kind = Item::Kind::restart;
  impl_->enqueue(it);
}

void StrikeRecognition::take(std::vector<VisitorStrike>& out) {
  VisitorStrike s;
  while (impl_->out.pop(s)) out.push_back(s);
}

RecognitionStats StrikeRecognition::stats() const {
  RecognitionStats s;
  s.running = true;
  s.samples = impl_->samples.load(std::memory_order_relaxed);
  s.dropped = impl_->dropped.load(std::memory_order_relaxed);
  s.events = impl_->events.load(std::memory_order_relaxed);
  s.events_dropped = impl_->events_dropped.load(std::memory_order_relaxed);
  return s;
}

void StrikeRecognition::drain_for_tests() const {
  const std::uint64_t target = impl_->pushed.load(std::memory_order_acquire);
  for (std::uint64_t d = impl_->done.load(std::memory_order_acquire); d < target;
       d = impl_->done.load(std::memory_order_acquire))
    impl_->done.wait(d, std::memory_order_acquire);
}

std::string describe(const VisitorStrike& s) {
  return fmt::format("{} {} {}, {:.0f} %, confidence {:.2f}, impact ({:.2f}, {:.2f}, {:.2f}) m, decided {:.1f} ms after its frame set",
                     recognition::to_string(s.limb), recognition::to_string(s.action), recognition::to_string(s.type),
                     100 * s.progress, s.confidence, s.impact[0], s.impact[1], s.impact[2],
                     s.decided_at >= 0 ? (s.decided_at - s.t) * 1e3 : 0.0);
}

}  // namespace kumite::app
