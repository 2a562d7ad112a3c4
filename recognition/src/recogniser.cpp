// The dual-buffer recogniser (see recognition.hpp).
#include <algorithm>
#include <cmath>

#include "kumite/common/error.hpp"
#include "kumite/recognition/recognition.hpp"

namespace kumite::recognition {

Recogniser::Recogniser(Model model) : model_(std::move(model)), frontend_(model_.settings.frontend) {
  if (model_.templates.empty()) throw Error("recognition", "model", "model has no templates");
  for (auto& l : limbs_) l.buffer.reserve(static_cast<std::size_t>(model_.settings.max_frames + 1));
  frames_.reserve(16);
}

void Recogniser::push(const PoseSample& s, std::vector<Event>& out) {
  frames_.clear();
  frontend_.push(s, frames_);
  now_ = s.t;
  run_frames(out);
}

void Recogniser::end_of_set(Timestamp t, std::vector<Event>& out) {
  frames_.clear();
  frontend_.end_of_set(t, frames_);
  now_ = std::max(now_, t);
  run_frames(out);
}

void Recogniser::run_frames(std::vector<Event>& out) {
  for (const Frame& f : frames_) {
    if (timing_) {
      const double t0 = thread_cpu_time();
      loop(f, out);
      const double dt = thread_cpu_time() - t0;
      loop_cpu_s_ += dt;
      loop_times_.push_back(dt);
    } else {
      loop(f, out);
    }
    ++loops_;
  }
}

void Recogniser::finish(Timestamp t, std::vector<Event>& out) {
  for (int l = 0; l < kLimbCount; ++l) {
    LimbState& st = limbs_[static_cast<std::size_t>(l)];
    if (st.state == State::active) out.push_back(cancel_event(l, st, t));
    st = LimbState{};
  }
}

void Recogniser::loop(const Frame& f, std::vector<Event>& out) {
  last_frame_ = f;
  for (int l = 0; l < kLimbCount; ++l) {
    limb_loop(f, l, out);
    LimbState& st = limbs_[static_cast<std::size_t>(l)];
    st.prev = f.limbs[static_cast<std::size_t>(l)];
    st.prev_valid = st.prev.valid;
  }
}

Recogniser::Best Recogniser::classify(int limb, int exclude) {
  Best best;
  const LimbKind kind = limb_kind(static_cast<Role>(limb + 1));
  const auto& buf = limbs_[static_cast<std::size_t>(limb)].buffer;
  for (std::size_t i = 0; i < model_.templates.size(); ++i) {
    const Template& t = model_.templates[i];
    if (t.kind != kind || static_cast<int>(i) == exclude || t.action == kNoneAction) continue;
    const DtwMatch m = dtw_open_end(buf, t.frames, scratch_);
    const double thr = t.threshold_at(static_cast<int>(buf.size()));
    if (m.distance < thr && m.distance / thr < best.distance) {
      best.index = static_cast<int>(i);
      best.distance = m.distance / thr;  // relative: 1 = at the threshold
      best.end = m.template_end;
    }
  }
  return best;
}

bool Recogniser::another_active(int limb) const {
  for (int o = 0; o < kLimbCount; ++o)
    if (o != limb && limbs_[static_cast<std::size_t>(o)].state == State::active) return true;
  return false;
}

bool Recogniser::closer_to_none(int limb, int strike) {
  const LimbKind kind = limb_kind(static_cast<Role>(limb + 1));
  const auto& buf = limbs_[static_cast<std::size_t>(limb)].buffer;
  const Template& st = model_.templates[static_cast<std::size_t>(strike)];
  // Compare the buffer's start (the length the "none" templates hold) with both.
  std::size_t longest = 0;
  for (const Template& t : model_.templates)
    if (t.kind == kind && t.action == kNoneAction) longest = std::max(longest, t.frames.size());
  if (longest == 0) return false;
  const std::size_t n = std::min(buf.size(), longest);
  const std::span<const Feature> head(buf.data(), n);
  const double ds = dtw_open_end(head, st.frames, scratch_).distance;
  for (const Template& t : model_.templates) {
    if (t.kind != kind || t.action != kNoneAction) continue;
    if (dtw_open_end(head, t.frames, scratch_).distance * model_.settings.none_margin < ds) return true;
  }
  return false;
}

Event Recogniser::cancel_event(int limb, const LimbState& st, Timestamp t) const {
  Event e;
  e.t = t;
  e.type = EventType::cancel;
  e.limb = static_cast<Role>(limb + 1);
  e.action = model_.templates[static_cast<std::size_t>(st.current)].action;
  e.progress = st.progress;
  e.confidence = st.confidence;
  e.impact = st.impact;
  return e;
}

Event Recogniser::make_event(const Frame& f, int limb, EventType type, int templ, const DtwMatch& m) {
  const Template& t = model_.templates[static_cast<std::size_t>(templ)];
  const Role role = static_cast<Role>(limb + 1);
  Event e;
  e.t = std::max(f.t, now_);
  e.type = type;
  e.limb = role;
  e.action = t.action;
  e.progress = std::clamp(static_cast<double>(m.template_end) / std::max(1, t.hit), 0.0, 1.0);
  const int n = static_cast<int>(limbs_[static_cast<std::size_t>(limb)].buffer.size());
  e.confidence = std::clamp(1.0 - m.distance / t.threshold_at(n), 0.0, 1.0);
  const Feature& a = t.frames[static_cast<std::size_t>(std::max(m.template_end, 0))];
  const Feature& b = t.frames[static_cast<std::size_t>(t.hit)];
  // Where the limb will be at full extension: the template's remaining way, in the room.
  const std::array<float, 3> rest{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const Vec3 d = m.template_end >= t.hit ? Vec3{0, 0, 0} : to_room_displacement(f, rest, is_left(role));
  const Vec3& p = f.limbs[static_cast<std::size_t>(limb)].room;
  e.impact = {p[0] + d[0], p[1] + d[1], p[2] + d[2]};
  LimbState& st = limbs_[static_cast<std::size_t>(limb)];
  // Past full extension the impact point stays where the limb was when it got there.
  if (m.template_end >= t.hit && st.state == State::active && st.current == templ && st.progress >= 1) e.impact = st.impact;
  st.progress = e.progress;
  st.confidence = e.confidence;
  st.impact = e.impact;
  return e;
}

void Recogniser::limb_loop(const Frame& f, int l, std::vector<Event>& out) {
  const RecogniserSettings& s = model_.settings;
  LimbState& st = limbs_[static_cast<std::size_t>(l)];
  const LimbFrame& lf = f.limbs[static_cast<std::size_t>(l)];
  if (!lf.valid) {
    if (st.state == State::active) out.push_back(cancel_event(l, st, std::max(f.t, now_)));
    st.state = State::idle;
    st.buffer.clear();
    st.null_run = 0;
    return;
  }
  st.null_run = lf.speed < s.null_speed ? st.null_run + 1 : 0;
  const bool null_signal = st.null_run >= s.null_frames;
  switch (st.state) {
    case State::idle:
      if (lf.speed > s.onset_speed) {
        // The buffer starts a loop early (lead_frames = 1): the loop before the onset.
        const bool lead = s.lead_frames > 0 && st.prev_valid;
        st.origin = lead ? st.prev.pos : lf.pos;
        st.buffer.clear();
        if (lead) st.buffer.push_back(make_feature(st.prev, st.origin, s.absolute_weight));
        st.buffer.push_back(make_feature(lf, st.origin, s.absolute_weight));
        st.state = State::collecting;
        st.slow_run = 0;
      }
      break;
    case State::discard:
      if (null_signal || ++st.discard_count >= s.discard_frames) st.state = State::idle;
      return;
    case State::collecting: {
      st.buffer.push_back(make_feature(lf, st.origin, s.absolute_weight));
      st.slow_run = lf.speed < s.onset_speed ? st.slow_run + 1 : 0;
      if (null_signal || (static_cast<int>(st.buffer.size()) > s.main_frames && st.slow_run >= s.rearm_frames)) {
        // Nothing matched and the limb slowed down: the next movement starts a new buffer.
        st.state = State::idle;
        return;
      }
      const int n = static_cast<int>(st.buffer.size());
      if (n >= s.main_frames) {
        const Best b = classify(l);
        if (b.index >= 0 && !(s.one_at_a_time && another_active(l)) && !closer_to_none(l, b.index)) {
          const Template& t = model_.templates[static_cast<std::size_t>(b.index)];
          // A late begin (supplementary buffer) only before full extension.
          if (n == s.main_frames || b.end < t.hit) {
            st.current = b.index;
            out.push_back(make_event(f, l, EventType::begin, b.index,
                                     DtwMatch{b.distance * t.threshold_at(n), b.end}));
            st.state = State::active;
            return;
          }
        }
      }
      if (n >= s.max_frames) {
        st.state = State::discard;
        st.discard_count = 0;
      }
      return;
    }
    case State::active: {
      st.buffer.push_back(make_feature(lf, st.origin, s.absolute_weight));
      const Template& cur = model_.templates[static_cast<std::size_t>(st.current)];
      const DtwMatch cm = dtw_open_end(st.buffer, cur.frames, scratch_);
      if (null_signal) {
        out.push_back(make_event(f, l, EventType::end, st.current, cm));
        st.state = State::idle;
        return;
      }
      const Best other = classify(l, st.current);
      const double cur_rel = cm.distance / cur.threshold_at(static_cast<int>(st.buffer.size()));
      if (other.index >= 0 && (cur_rel >= 1 || other.distance < s.switch_margin * cur_rel)) {
        const Template& t = model_.templates[static_cast<std::size_t>(other.index)];
        const bool same_action = t.action == cur.action;  // another style of the same strike
        st.current = other.index;
        const Event e = make_event(f, l, EventType::switch_, other.index,
                                   DtwMatch{other.distance * t.threshold_at(static_cast<int>(st.buffer.size())), other.end});
        if (!same_action) out.push_back(e);
      } else if (cur_rel >= 1) {
        out.push_back(make_event(f, l, EventType::cancel, st.current, cm));
        st.state = State::discard;
        st.discard_count = 0;
        return;
      } else {
        make_event(f, l, EventType::begin, st.current, cm);  // updates progress / impact only
      }
      if (static_cast<int>(st.buffer.size()) >= s.max_frames) {
        out.push_back(make_event(f, l, EventType::end, st.current,
                                 dtw_open_end(st.buffer, model_.templates[static_cast<std::size_t>(st.current)].frames, scratch_)));
        st.state = State::discard;
        st.discard_count = 0;
      }
      return;
    }
  }
}

std::vector<Event> recognise(const Model& model, std::span<const PoseSample> samples) {
  Recogniser r(model);
  std::vector<Event> out;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    r.push(samples[i], out);
    if (i + 1 == samples.size() || samples[i + 1].t != samples[i].t) r.end_of_set(samples[i].t, out);
  }
  r.finish(samples.empty() ? 0 : samples.back().t, out);
  return out;
}

}  // namespace kumite::recognition
