// The learned recogniser (see learned.hpp): the .klearn model file, inference, events.
#include "kumite/recognition/learned.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include <Eigen/Core>
#include <fmt/format.h>

#include "kumite/common/error.hpp"
#include "kumite/common/text.hpp"
#include "kumite/common/time.hpp"
#include "model_text.hpp"

namespace kumite::recognition {

namespace {
constexpr std::string_view kMagic = "kumite-learned-model";
constexpr int kKernel1 = 4, kDilation1 = 1, kKernel2 = 4, kDilation2 = 4;
static_assert(1 + (kKernel1 - 1) * kDilation1 + (kKernel2 - 1) * kDilation2 == kLearnedWindow);

/// Base64 (RFC 4648, with padding) -> bytes; false on a malformed string.
bool decode_base64(std::string_view s, std::vector<unsigned char>& out) {
  auto val = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  out.clear();
  if (s.size() % 4 != 0) return false;
  for (std::size_t i = 0; i < s.size(); i += 4) {
    int v[4];
    int pad = 0;
    for (int k = 0; k < 4; ++k) {
      const char c = s[i + static_cast<std::size_t>(k)];
      if (c == '=' && i + 4 == s.size() && k >= 2) {
        v[k] = 0;
        ++pad;
      } else {
        if (pad) return false;
        v[k] = val(c);
        if (v[k] < 0) return false;
      }
    }
    const unsigned n = (static_cast<unsigned>(v[0]) << 18) | (static_cast<unsigned>(v[1]) << 12) |
                       (static_cast<unsigned>(v[2]) << 6) | static_cast<unsigned>(v[3]);
    out.push_back(static_cast<unsigned char>(n >> 16));
    if (pad < 2) out.push_back(static_cast<unsigned char>((n >> 8) & 0xff));
    if (pad < 1) out.push_back(static_cast<unsigned char>(n & 0xff));
  }
  return true;
}

struct SettingField {
  std::string_view name;
  double lo, hi;
};
constexpr SettingField kSettings[] = {
    {"loop_hz", 10, 1000},          {"smoothing_tau_s", 1e-4, 1}, {"heading_tau_s", 1e-3, 10},
    {"height_tau_s", 1e-2, 100},    {"velocity_weight", 0, 10},   {"max_gap_s", 1e-3, 10},
    {"begin_probability", 0.01, 1}, {"begin_progress", 0, 1},     {"end_frames", 1, 1000},
    {"confirm_frames", 1, 1000},    {"min_speed", 0, 20},
};
double& setting_ref(LearnedSettings& s, std::string_view name) {
  if (name == "loop_hz") return s.frontend.loop_hz;
  if (name == "smoothing_tau_s") return s.frontend.smoothing_tau_s;
  if (name == "heading_tau_s") return s.frontend.heading_tau_s;
  if (name == "height_tau_s") return s.frontend.height_tau_s;
  if (name == "velocity_weight") return s.frontend.velocity_weight;
  if (name == "max_gap_s") return s.frontend.max_gap_s;
  if (name == "begin_probability") return s.begin_probability;
  if (name == "min_speed") return s.min_speed;
  return s.begin_progress;  // end_frames and confirm_frames are integers: handled apart
}

double sigmoid(double x) { return 1 / (1 + std::exp(-x)); }
}  // namespace

LearnedModel parse_learned_model(std::string_view text, std::string_view source) {
  using detail::split;
  auto fail = [&](int line, std::string_view key, std::string_view msg) {
    return file_error("recognition", "learned_model", source, line, key, msg);
  };
  const auto lines = detail::lines_of(text);
  if (lines.empty()) throw fail(1, "format", "empty file: not a kumite learned model");
  {
    const auto w = split(trim_blanks(lines[0]));
    if (w.size() != 2 || w[0] != kMagic)
      throw fail(1, "format", fmt::format("not a kumite learned model (first line must be \"{} {}\")", kMagic,
                                          LearnedModel::kVersion));
    if (w[1] != std::to_string(LearnedModel::kVersion))
      throw fail(1, "version", fmt::format("model version {} is not the version this build reads ({})", w[1],
                                           LearnedModel::kVersion));
  }
  if (lines.size() < 2) throw fail(2, "checksum", "missing");
  {
    const auto w = split(trim_blanks(lines[1]));
    if (w.size() != 3 || w[0] != "checksum" || w[1] != "fnv1a64")
      throw fail(2, "checksum", "expected \"checksum fnv1a64 <16 hex digits>\"");
    const std::size_t body_start = lines[0].size() + 1 + lines[1].size() + 1;
    const std::string_view body = body_start <= text.size() ? text.substr(body_start) : std::string_view{};
    if (w[2] != fmt::format("{:016x}", detail::fnv1a64(body)))
      throw fail(2, "checksum", "does not match the contents (file damaged or edited)");
  }
  auto number = [&](std::string_view tok, int line, std::string_view key, double lo, double hi) {
    double v = 0;
    const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec != std::errc() || p != tok.data() + tok.size()) throw fail(line, key, fmt::format("'{}' is not a number", tok));
    if (!std::isfinite(v) || v < lo || v > hi) throw fail(line, key, fmt::format("{} is outside [{}, {}]", tok, lo, hi));
    return v;
  };
  auto integer = [&](std::string_view tok, int line, std::string_view key, int lo, int hi) {
    int v = 0;
    const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v);
    if (ec != std::errc() || p != tok.data() + tok.size()) throw fail(line, key, fmt::format("'{}' is not an integer", tok));
    if (v < lo || v > hi) throw fail(line, key, fmt::format("{} is outside [{}, {}]", v, lo, hi));
    return v;
  };
  LearnedModel m;
  bool ended = false;
  std::vector<bool> seen(std::size(kSettings), false);
  std::vector<unsigned char> bytes;
  for (std::size_t li = 2; li < lines.size(); ++li) {
    const int line = static_cast<int>(li + 1);
    const std::string_view l = trim_blanks(lines[li]);
    if (l.empty()) continue;
    if (ended) throw fail(line, "end", "text after \"end\"");
    const auto w = split(l);
    if (w[0] == "note") {
      m.note = std::string(trim_blanks(l.substr(4)));
    } else if (w[0] == "setting") {
      if (w.size() != 3) throw fail(line, "setting", "expected \"setting <name> <value>\"");
      bool known = false;
      for (std::size_t i = 0; i < std::size(kSettings); ++i) {
        if (kSettings[i].name != w[1]) continue;
        const double v = number(w[2], line, w[1], kSettings[i].lo, kSettings[i].hi);
        if (w[1] == "end_frames" || w[1] == "confirm_frames") {
          if (v != std::floor(v)) throw fail(line, w[1], fmt::format("{} is not a whole number", w[2]));
          (w[1] == "end_frames" ? m.settings.end_frames : m.settings.confirm_frames) = static_cast<int>(v);
        } else {
          setting_ref(m.settings, w[1]) = v;
        }
        seen[i] = known = true;
      }
      if (!known) throw fail(line, w[1], "unknown setting");
    } else if (w[0] == "net") {
      // net <kind> classes <n> <names...> input 6 hidden <H> kernel1 4 dilation1 1 kernel2 4 dilation2 4
      const std::string_view usage =
          "expected \"net <hand|foot> classes <n> <names...> input 6 hidden <H> kernel1 4 dilation1 1 kernel2 4 dilation2 4\"";
      if (w.size() < 4 || w[2] != "classes") throw fail(line, "net", usage);
      LearnedNet net;
      const auto kind = limb_kind_from_string(w[1]);
      if (!kind) throw fail(line, "net", fmt::format("'{}' is not hand or foot", w[1]));
      net.kind = *kind;
      if (m.net(net.kind)) throw fail(line, "net", fmt::format("a second {} net", w[1]));
      const int nc = integer(w[3], line, "classes", 2, 64);
      if (w.size() != static_cast<std::size_t>(4 + nc + 12)) throw fail(line, "net", usage);
      for (int c = 0; c < nc; ++c) {
        const std::string_view name = w[static_cast<std::size_t>(4 + c)];
        if (name.empty() || name.size() > 64 ||
            !std::all_of(name.begin(), name.end(), [](char ch) { return (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '_'; }))
          throw fail(line, "classes", fmt::format("'{}' is not a name (a-z, 0-9, _)", name));
        net.classes.emplace_back(name);
      }
      if (net.classes[0] != kNoneAction) throw fail(line, "classes", "the first class must be \"none\"");
      const std::size_t k = static_cast<std::size_t>(4 + nc);
      const std::pair<std::string_view, int> fixed[] = {{"input", kLearnedInputs}, {"kernel1", kKernel1}, {"dilation1", kDilation1},
                                                        {"kernel2", kKernel2}, {"dilation2", kDilation2}};
      const std::string_view keys[] = {"input", "hidden", "kernel1", "dilation1", "kernel2", "dilation2"};
      for (std::size_t i = 0; i < 6; ++i)
        if (w[k + 2 * i] != keys[i]) throw fail(line, "net", usage);
      net.hidden = integer(w[k + 3], line, "hidden", 1, 1024);
      for (const auto& [key, want] : fixed) {
        std::size_t i = 0;
        while (keys[i] != key) ++i;
        const int v = integer(w[k + 2 * i + 1], line, key, 0, 1000);
        if (v != want) throw fail(line, key, fmt::format("{} is not {} (the architecture this build runs)", v, want));
      }
      const int h = net.hidden, nco = nc + 1;
      struct T { std::string_view name; std::vector<float>* dst; std::vector<int> dims; double lim; };
      const T tensors[] = {{"mean", &net.mean, {kLearnedInputs}, 1e3},
                           {"std", &net.std, {kLearnedInputs}, 1e3},
                           {"conv1_weight", &net.conv1_weight, {h, kLearnedInputs, kKernel1}, 1e3},
                           {"conv1_bias", &net.conv1_bias, {h}, 1e3},
                           {"conv2_weight", &net.conv2_weight, {h, h, kKernel2}, 1e3},
                           {"conv2_bias", &net.conv2_bias, {h}, 1e3},
                           {"out_weight", &net.out_weight, {nco, h}, 1e3},
                           {"out_bias", &net.out_bias, {nco}, 1e3},
                           {"impact", &net.impact, {nc, 3}, 100}};
      for (const T& t : tensors) {
        ++li;
        const int tl = static_cast<int>(li + 1);
        if (li >= lines.size()) throw fail(tl, t.name, "missing (file cut short)");
        const auto v = split(trim_blanks(lines[li]));
        if (v.size() != t.dims.size() + 3 || v[0] != "tensor" || v[1] != t.name)
          throw fail(tl, t.name, fmt::format("expected \"tensor {} <{} dims> <base64>\"", t.name, t.dims.size()));
        std::size_t count = 1;
        for (std::size_t d = 0; d < t.dims.size(); ++d) {
          const int got = integer(v[2 + d], tl, t.name, 1, 1 << 20);
          if (got != t.dims[d]) throw fail(tl, t.name, fmt::format("dimension {} is {}, expected {}", d, got, t.dims[d]));
          count *= static_cast<std::size_t>(got);
        }
        if (!decode_base64(v.back(), bytes)) throw fail(tl, t.name, "malformed base64");
        if (bytes.size() != count * 4) throw fail(tl, t.name, fmt::format("{} bytes, expected {} float32", bytes.size(), count));
        t.dst->resize(count);
        for (std::size_t i = 0; i < count; ++i) {
          std::uint32_t u = static_cast<std::uint32_t>(bytes[4 * i]) | (static_cast<std::uint32_t>(bytes[4 * i + 1]) << 8) |
                            (static_cast<std::uint32_t>(bytes[4 * i + 2]) << 16) | (static_cast<std::uint32_t>(bytes[4 * i + 3]) << 24);
          float f;
          std::memcpy(&f, &u, 4);
          if (!std::isfinite(f) || std::abs(f) > t.lim)
            throw fail(tl, t.name, fmt::format("value {} at {} is not finite or outside [-{}, {}]", f, i, t.lim, t.lim));
          (*t.dst)[i] = f;
        }
      }
      for (float s : net.std)
        if (!(s > 1e-6f)) throw fail(line, "std", "an input's standard deviation is not positive");
      m.nets.push_back(std::move(net));
    } else if (w[0] == "end") {
      ended = true;
    } else {
      throw fail(line, w[0], "unknown line");
    }
  }
  if (!ended) throw fail(static_cast<int>(lines.size()), "end", "missing (file cut short)");
  for (std::size_t i = 0; i < seen.size(); ++i)
    if (!seen[i]) throw fail(0, kSettings[i].name, "setting missing");
  if (m.nets.empty()) throw fail(0, "net", "the model has no network");
  return m;
}

LearnedModel read_learned_model(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw file_error("recognition", "io", path.string(), 0, "", "cannot open the learned model file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_learned_model(ss.str(), path.string());
}

void learned_infer(const LearnedNet& net, std::span<const LearnedInput, kLearnedWindow> window, LearnedOutput& out,
                   std::vector<float>& scratch) {
  using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  using CMap = Eigen::Map<const RowMajor>;
  using VMap = Eigen::Map<Eigen::VectorXf>;
  using CVMap = Eigen::Map<const Eigen::VectorXf>;
  const int H = net.hidden, C = static_cast<int>(net.classes.size());
  constexpr int kPatch = kLearnedInputs * kKernel1;
  scratch.resize(static_cast<std::size_t>(kPatch + kKernel2 * H + 2 * H + C + 1));  // no allocation once sized
  VMap patch(scratch.data(), kPatch);                 // conv1's input [i][k]
  VMap h1(patch.data() + kPatch, kKernel2 * H);       // conv2's input [c][k]
  VMap h2(h1.data() + kKernel2 * H, H);
  VMap logits(h2.data() + H, C + 1);
  VMap col(logits.data() + C + 1, H);
  const CMap w1(net.conv1_weight.data(), H, kPatch);  // torch [out][in][k]
  const CMap w2(net.conv2_weight.data(), H, H * kKernel2);
  const CMap wo(net.out_weight.data(), C + 1, H);
  // conv2 (dilation 4) reads conv1's outputs at window offsets 0, 4, 8, 12; conv1 output j
  // reads the (normalised) inputs j .. j+3.
  for (int k2 = 0; k2 < kKernel2; ++k2) {
    const int j = k2 * kDilation2;
    for (int i = 0; i < kLearnedInputs; ++i)
      for (int k = 0; k < kKernel1; ++k)
        patch[i * kKernel1 + k] = (window[static_cast<std::size_t>(j + k * kDilation1)][static_cast<std::size_t>(i)] -
                                   net.mean[static_cast<std::size_t>(i)]) / net.std[static_cast<std::size_t>(i)];
    col.noalias() = w1 * patch;
    col = (col + CVMap(net.conv1_bias.data(), H)).cwiseMax(0.0f);
    for (int c = 0; c < H; ++c) h1[c * kKernel2 + k2] = col[c];
  }
  h2.noalias() = w2 * h1;
  h2 = (h2 + CVMap(net.conv2_bias.data(), H)).cwiseMax(0.0f);
  logits.noalias() = wo * h2;
  logits += CVMap(net.out_bias.data(), C + 1);
  out.probabilities.resize(static_cast<std::size_t>(C));
  const float mx = logits.head(C).maxCoeff();
  double sum = 0;
  for (int c = 0; c < C; ++c) sum += std::exp(static_cast<double>(logits[c] - mx));
  for (int c = 0; c < C; ++c)
    out.probabilities[static_cast<std::size_t>(c)] = static_cast<float>(std::exp(static_cast<double>(logits[c] - mx)) / sum);
  out.progress = static_cast<float>(sigmoid(logits[C]));
}

// ---- LearnedRecogniser ------------------------------------------------------------------------

LearnedRecogniser::LearnedRecogniser(LearnedModel model)
    : model_(std::move(model)), frontend_(model_.settings.frontend) {
  if (model_.nets.empty()) throw Error("recognition", "learned_model", "learned model has no network");
  frames_.reserve(16);
}

void LearnedRecogniser::push(const PoseSample& s, std::vector<Event>& out) {
  frames_.clear();
  frontend_.push(s, frames_);
  now_ = s.t;
  run_frames(out);
}

void LearnedRecogniser::end_of_set(Timestamp t, std::vector<Event>& out) {
  frames_.clear();
  frontend_.end_of_set(t, frames_);
  now_ = std::max(now_, t);
  run_frames(out);
}

void LearnedRecogniser::run_frames(std::vector<Event>& out) {
  for (const Frame& f : frames_) {
    if (timing_) {
      const double t0 = thread_cpu_time();
      loop(f, out);
      loop_times_.push_back(thread_cpu_time() - t0);
    } else {
      loop(f, out);
    }
    ++loops_;
  }
}

void LearnedRecogniser::finish(Timestamp t, std::vector<Event>& out) {
  for (int l = 0; l < kLimbCount; ++l) {
    LimbState& st = limbs_[static_cast<std::size_t>(l)];
    if (st.active) out.push_back(cancel_event(l, st, t));
    st = LimbState{};
  }
}

Event LearnedRecogniser::cancel_event(int limb, const LimbState& st, Timestamp t) const {
  const LearnedNet* net = model_.net(limb_kind(static_cast<Role>(limb + 1)));
  Event e;
  e.t = t;
  e.type = EventType::cancel;
  e.limb = static_cast<Role>(limb + 1);
  e.action = net ? net->classes[static_cast<std::size_t>(st.current)] : std::string(kNoneAction);
  e.progress = st.progress;
  e.confidence = st.confidence;
  e.impact = st.impact;
  return e;
}

Event LearnedRecogniser::event(const Frame& f, int limb, EventType type, const LearnedNet& net, int cls) {
  LimbState& st = limbs_[static_cast<std::size_t>(limb)];
  const Role role = static_cast<Role>(limb + 1);
  const LimbFrame& lf = f.limbs[static_cast<std::size_t>(limb)];
  Event e;
  e.t = std::max(f.t, now_);
  e.type = type;
  e.limb = role;
  e.action = net.classes[static_cast<std::size_t>(cls)];
  e.progress = std::clamp(static_cast<double>(output_.progress), 0.0, 1.0);
  e.confidence = output_.probabilities[static_cast<std::size_t>(cls)];
  // Impact: the rest of the way (1 - progress) from here to the class's mean full-extension
  // point (head frame, head heights), turned back into the room.
  const float rest = static_cast<float>(1 - e.progress);
  const float* hit = net.impact.data() + static_cast<std::size_t>(cls) * 3;
  const std::array<float, 3> d{rest * (hit[0] - lf.pos[0]), rest * (hit[1] - lf.pos[1]), rest * (hit[2] - lf.pos[2])};
  const Vec3 dr = to_room_displacement(f, d, is_left(role));
  e.impact = {lf.room[0] + dr[0], lf.room[1] + dr[1], lf.room[2] + dr[2]};
  st.progress = e.progress;
  st.confidence = e.confidence;
  st.impact = e.impact;
  return e;
}

void LearnedRecogniser::loop(const Frame& f, std::vector<Event>& out) {
  const LearnedSettings& s = model_.settings;
  for (int l = 0; l < kLimbCount; ++l) {
    LimbState& st = limbs_[static_cast<std::size_t>(l)];
    const LimbFrame& lf = f.limbs[static_cast<std::size_t>(l)];
    const LearnedNet* net = model_.net(limb_kind(static_cast<Role>(l + 1)));
    if (!net) continue;
    if (!lf.valid) {
      if (st.active) out.push_back(cancel_event(l, st, std::max(f.t, now_)));
      st = LimbState{};
      continue;
    }
    // History: the last 16 loops, oldest first; a limb seen for fewer loops repeats its first.
    const LearnedInput in{lf.pos[0], lf.pos[1], lf.pos[2], lf.vel[0], lf.vel[1], lf.vel[2]};
    if (st.filled == 0) st.history.fill(in);
    else {
      std::move(st.history.begin() + 1, st.history.end(), st.history.begin());
      st.history.back() = in;
    }
    st.filled = std::min(st.filled + 1, kLearnedWindow);
    learned_infer(*net, st.history, output_, scratch_);
    const auto& p = output_.probabilities;
    int best = 1;
    for (int c = 2; c < static_cast<int>(p.size()); ++c)
      if (p[static_cast<std::size_t>(c)] > p[static_cast<std::size_t>(best)]) best = c;
    const bool strike = p[static_cast<std::size_t>(best)] >= s.begin_probability && p[static_cast<std::size_t>(best)] > p[0];
    if (!st.active) {
      const bool candidate = strike && output_.progress >= s.begin_progress && lf.speed >= s.min_speed;
      st.candidate_run = candidate ? (st.candidate == best ? st.candidate_run + 1 : 1) : 0;
      st.candidate = best;
      if (candidate && st.candidate_run >= s.confirm_frames) {
        st.active = true;
        st.current = best;
        st.none_run = 0;
        out.push_back(event(f, l, EventType::begin, *net, best));
      }
      continue;
    }
    const bool none_wins = p[0] >= p[static_cast<std::size_t>(best)];
    st.none_run = none_wins ? st.none_run + 1 : 0;
    if (st.none_run >= s.end_frames) {
      // The strike as it last was (progress, confidence, impact): "none" has won since.
      Event e = cancel_event(l, st, std::max(f.t, now_));
      e.type = EventType::end;
      out.push_back(e);
      st.active = false;
    } else if (strike && best != st.current) {
      st.current = best;
      out.push_back(event(f, l, EventType::switch_, *net, best));
    } else if (!none_wins) {
      event(f, l, EventType::begin, *net, st.current);  // updates progress / impact only
    }
  }
}

}  // namespace kumite::recognition
