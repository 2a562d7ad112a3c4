// App figures: CPU per frame excluding GPU draw (4 walls in stereo), headless render time per
// 1920x1080 wall image on llvmpipe, and a cluster STATE's encoding and decoding with and
// without the master's console.
//   build/bin/kumite_app_bench --benchmark_format=json
#include <benchmark/benchmark.h>

#include <ctime>
#include <functional>
#include <memory>

#include <Eigen/Core>
#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>

#include "kumite/app/bodies.hpp"
#include "kumite/app/config.hpp"
#include "kumite/app/frame_states.hpp"
#include "kumite/app/headless.hpp"
#include "kumite/app/installation.hpp"
#include "kumite/app/renderer.hpp"
#include "kumite/app/scene.hpp"
#include "kumite/content/fighter.hpp"

using namespace kumite::app;

namespace {

/// A synthetic 31-joint chain figure (the CMU skeleton's joint count): bench data only.
struct Figure {
  std::vector<Eigen::Vector3d> joints;
  std::vector<int> parents;
  std::vector<float> radii;
  kumite::content::FighterFrame frame() const {
    kumite::content::FighterFrame f;
    f.joints = joints;
    f.parents = parents;
    f.joint_radii_m = radii;
    f.target = Eigen::Vector3d(0, 1.6, -1.0);
    return f;
  }
};

Figure figure() {
  Figure f;
  for (int i = 0; i < 31; ++i) {
    const int parent = i == 0 ? -1 : (i % 5 == 0 ? 0 : i - 1);
    f.joints.emplace_back(0.05 * (i % 5) - 0.1, 0.06 * i, -2.5 + 0.01 * i);
    f.parents.push_back(parent);
    f.radii.push_back(0.05f);
  }
  return f;
}

std::vector<WallFrame> demo_walls() {
  const auto cfg = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  std::vector<WallFrame> w;
  for (const auto& c : cfg.walls) w.push_back(wall_frame(c));
  return w;
}

void BM_PlanViews4WallsStereo(benchmark::State& state) {
  const auto walls = demo_walls();
  WallViews views;
  HeadPose head;
  double x = 0;
  for (auto _ : state) {
    head.position.x = (x += 1e-6);
    const Eyes eyes = eyes_from_head(head, 0.064, {0, -0.03, -0.01});
    benchmark::DoNotOptimize(plan_views(walls, eyes, 0.05, 100, views));
  }
}
BENCHMARK(BM_PlanViews4WallsStereo);

void BM_PlanFighter31Joints(benchmark::State& state) {
  const Figure fig = figure();
  const auto f = fig.frame();
  std::vector<DrawItem> items;
  for (auto _ : state) {
    plan_fighter(f, character_colour(0), items);
    benchmark::DoNotOptimize(items.data());
  }
}
BENCHMARK(BM_PlanFighter31Joints);

/// The whole CPU step of the demo installation (tracking poll, orders, eyes, 4 walls x 2
/// eyes, console state), without the fighter when content is not built in.
void BM_InstallationStepDemo(benchmark::State& state) {
  auto cfg = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  cfg.orders_script.reset();
  cfg.tracking.source = TrackingSource::none;
  Installation inst(cfg, make_fixed_head_input("bench"), {});
  double t = 1000;
  inst.start(t);
  for (auto _ : state) benchmark::DoNotOptimize(inst.step(t += 1.0 / 60).frame);
  state.counters["walls"] = static_cast<double>(cfg.walls.size());
}
BENCHMARK(BM_InstallationStepDemo);

/// One 1920x1080 wall image on llvmpipe: clear + room + 31-joint figure, glFinish'ed by the
/// read-back (arg 1) or not read back (arg 0; then the next frame's clear waits for it).
void BM_HeadlessWall1080p(benchmark::State& state) {
  HeadlessContext context;
  const auto walls = demo_walls();
  Renderer renderer(walls);
  OffscreenTarget target(1920, 1080);
  std::vector<DrawItem> items;
  plan_fighter(figure().frame(), character_colour(0), items);
  const EyeView view = off_axis(walls[0], {0, 1.67, 0}, 0.05, 100);
  std::vector<std::uint8_t> rgba;
  for (auto _ : state) {
    target.bind();
    renderer.clear(0, 0, 1920, 1080);
    renderer.draw(view, items);
    target.read(rgba);
  }
  state.counters["px"] = 1920.0 * 1080.0;
}
BENCHMARK(BM_HeadlessWall1080p)->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// One headless frame of the demo: its 4 walls x 2 eyes, each image read back (as when the
/// frame's PNGs are saved, without the encoding). Arg 0: the demo's resolutions (3 walls
/// 1920x1080, the floor 1920x1920); arg 1: 320x180 each, as tests/app/test_demo.cpp renders.
void BM_HeadlessDemoFrame(benchmark::State& state) {
  HeadlessContext context;
  const auto cfg = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
  const auto walls = demo_walls();
  Renderer renderer(walls);
  std::vector<std::unique_ptr<OffscreenTarget>> targets;
  for (const auto& w : cfg.walls) {
    const auto res = state.range(0) == 0 ? w.resolution : std::array<int, 2>{320, 180};
    targets.push_back(std::make_unique<OffscreenTarget>(res[0], res[1]));
  }
  std::vector<DrawItem> items;
  plan_fighter(figure().frame(), character_colour(0), items);
  WallViews views;
  HeadPose head;
  head.position = {0, 1.67, 0};
  const Eyes eyes = eyes_from_head(head, 0.064, {0, -0.03, -0.01});
  views.resize(walls.size());
  plan_views(walls, eyes, 0.05, 100, views);
  std::vector<std::uint8_t> rgba;
  double px = 0;
  for (auto _ : state) {
    for (std::size_t w = 0; w < targets.size(); ++w)
      for (std::size_t e = 0; e < 2; ++e) {
        targets[w]->bind();
        renderer.clear(0, 0, targets[w]->width(), targets[w]->height());
        renderer.draw(views[w][e], items);
        targets[w]->read(rgba);
      }
  }
  for (const auto& t : targets) px += 2.0 * t->width() * t->height();
  state.counters["images"] = 2.0 * static_cast<double>(targets.size());
  state.counters["px_per_frame"] = px;
}
BENCHMARK(BM_HeadlessDemoFrame)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// The demo's fighter (kenji) in the middle of a right punch, from the demo database: a real
/// pose for the skinned body. Null when there is no demo data.
struct DemoFighter {
  InstallationConfig cfg;
  std::unique_ptr<Installation> inst;
  const FrameData* frame = nullptr;
  /// The demo with a fixed head and no orders script, `adjust`ed, stepped `frames` updates at
  /// 60 Hz with a right punch ordered at the 5th.
  explicit DemoFighter(const std::function<void(InstallationConfig&)>& adjust = [](InstallationConfig& c) {
    c.fighter.initial_character = 0;
  }, int frames = 60) {
    cfg = load_installation_config(KUMITE_SOURCE_DIR + "/config/demo.toml");
    cfg.fighter.database = KUMITE_BINARY_DIR + "/demo/fighter.kdb";
    cfg.tracking.source = TrackingSource::none;
    cfg.orders_script.reset();
    adjust(cfg);
    inst = std::make_unique<Installation>(cfg, make_fixed_head_input("bench"), InstallationOptions{});
    double t = 1000;
    inst->start(t);
    for (int i = 0; i < frames; ++i) {
      if (i == 5) inst->order({t, kumite::OrderKind::punch_right, -1});
      frame = &inst->step(t += 1.0 / 60);
    }
  }
};

/// The skinned body's CPU part per frame: the retarget of the fighter's pose onto kenji's body
/// and its joint palette (FighterBodies::pose; the GPU then skins).
void BM_BodyRetargetPalette(benchmark::State& state) {
  DemoFighter d;
  if (!d.frame->fighter.present) {
    state.SkipWithError("no demo database (scripts/setup.sh)");
    return;
  }
  FighterBodies bodies(d.cfg);
  for (auto _ : state) benchmark::DoNotOptimize(bodies.pose(d.frame->fighter));
}
BENCHMARK(BM_BodyRetargetPalette);

/// One 1920x1080 front-wall image of the demo's fighter mid-punch on llvmpipe, read back. Arg:
/// 0 capsules in the void (as before), 1 capsules in the hall, 2 the skinned body in the hall
/// (begin_frame's retarget and palette upload included, once per image here: a frame does it
/// once for all its 8 images).
void BM_HeadlessWallLook(benchmark::State& state) {
  HeadlessContext context;
  DemoFighter d;
  if (!d.frame->fighter.present) {
    state.SkipWithError("no demo database (scripts/setup.sh)");
    return;
  }
  auto cfg = d.cfg;
  cfg.render.fighter = state.range(0) == 2 ? FighterLook::skinned : FighterLook::capsules;
  cfg.render.hall = state.range(0) > 0;
  Renderer renderer(d.inst->walls());
  renderer.configure(cfg);
  OffscreenTarget target(1920, 1080);
  const EyeView view = off_axis(d.inst->walls()[0], {0, 1.67, 0}, 0.05, 100);
  std::vector<std::uint8_t> rgba;
  for (auto _ : state) {
    renderer.begin_frame(d.frame->fighter);
    target.bind();
    renderer.clear(0, 0, 1920, 1080);
    renderer.draw(view, d.frame->items);
    target.read(rgba);
  }
  state.counters["skinned"] = renderer.body_frame() != nullptr;
}
BENCHMARK(BM_HeadlessWallLook)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinTime(2.0);

/// The headless demo's drawing of one frame (every wall of config/demo.toml at its resolution,
/// both eyes, glFinish) in four looks, interleaved in every iteration so that a loaded machine
/// slows them alike: capsules and the skinned body, in the void and in the hall. The head moves
/// 1 cm a frame on a circle, as a visitor's does (views that never repeat; only the floor
/// wall's image of the floor does, for every eye). Counters: the median ms per frame of each
/// look and the hall's factor over the void (the installation's target: at most 1.5 on
/// llvmpipe); `hall_cpu_factor_*` the same factor in the process's CPU time (the main thread's
/// and llvmpipe's rasteriser threads'), which a machine loaded by other work spreads less than
/// the wall-clock factor.
void BM_DemoFrameLooks(benchmark::State& state) {
  HeadlessContext context;
  DemoFighter d;
  if (!d.frame->fighter.present) {
    state.SkipWithError("no demo database (scripts/setup.sh)");
    return;
  }
  auto cfg = d.cfg;
  cfg.render.fighter = FighterLook::capsules;
  Renderer capsules(d.inst->walls());
  capsules.configure(cfg);
  cfg.render.fighter = FighterLook::skinned;
  Renderer skinned(d.inst->walls());
  skinned.configure(cfg);
  std::vector<std::unique_ptr<OffscreenTarget>> targets;
  for (const auto& w : d.cfg.walls) targets.push_back(std::make_unique<OffscreenTarget>(w.resolution[0], w.resolution[1]));
  struct Look {
    const char* name;
    Renderer* renderer;
    bool hall;
    std::vector<double> ms;
    std::vector<double> cpu_ms;  ///< the process's CPU time (every llvmpipe thread's)
  };
  std::array<Look, 4> looks{{{"void_capsules_ms", &capsules, false, {}, {}},
                             {"void_skinned_ms", &skinned, false, {}, {}},
                             {"hall_capsules_ms", &capsules, true, {}, {}},
                             {"hall_skinned_ms", &skinned, true, {}, {}}}};
  auto process_cpu_s = [] {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
  };
  const FrameData& f = *d.frame;
  const auto& walls = d.inst->walls();
  std::vector<std::array<EyeView, 2>> views(walls.size());
  std::size_t turn = 0;
  for (auto _ : state) {
    const double a = 0.2 * static_cast<double>(turn);  // 5 cm circle, 1 cm a frame
    const glm::dvec3 head(0.05 * std::sin(a), 1.67, 0.05 * std::cos(a));
    for (std::size_t w = 0; w < walls.size(); ++w)
      for (std::size_t e = 0; e < 2; ++e)
        views[w][e] = off_axis(walls[w], head + glm::dvec3(e == 0 ? -0.032 : 0.032, 0, 0), 0.05, 100);
    for (std::size_t k = 0; k < looks.size(); ++k) {
      Look& look = looks[(k + turn) % looks.size()];  // a different look first each time
      SceneOptions o = look.renderer->options();
      o.hall = look.hall;
      look.renderer->set_options(o);
      const double t0 = kumite::now(), c0 = process_cpu_s();
      look.renderer->begin_frame(f.fighter);
      for (std::size_t w = 0; w < targets.size(); ++w)
        for (std::size_t e = 0; e < 2; ++e) {
          targets[w]->bind();
          look.renderer->clear(0, 0, targets[w]->width(), targets[w]->height());
          look.renderer->draw(views[w][e], f.items);
          glFlush();
        }
      glFinish();
      look.ms.push_back((kumite::now() - t0) * 1e3);
      look.cpu_ms.push_back((process_cpu_s() - c0) * 1e3);
    }
    ++turn;
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0.0 : v[v.size() / 2];
  };
  for (const Look& l : looks) state.counters[l.name] = median(l.ms);
  state.counters["hall_factor_skinned"] = median(looks[3].ms) / median(looks[1].ms);
  state.counters["hall_factor_capsules"] = median(looks[2].ms) / median(looks[0].ms);
  // The same in CPU time (all of the process's threads): the work the hall adds, which other
  // load on the machine stretches less than the wall-clock time.
  state.counters["hall_cpu_factor_skinned"] = median(looks[3].cpu_ms) / median(looks[1].cpu_ms);
  state.counters["hall_cpu_factor_capsules"] = median(looks[2].cpu_ms) / median(looks[0].cpu_ms);
}
BENCHMARK(BM_DemoFrameLooks)->Unit(benchmark::kMillisecond)->Iterations(21);

/// The demo stepped 2 s with a fixed head, the fighter sparring (config/demo-spar.toml's
/// planner, at a fighting distance the fixed head is at: its line names the next decision) and
/// a right punch ordered: a cluster master's frame and its console for that frame.
DemoFighter demo_state() {
  return DemoFighter(
      [](InstallationConfig& c) {
        c.fighter.planner->mode = kumite::content::PlannerMode::spar;
        c.fighter.planner->fighting_distance_m = 2.5;
      },
      120);
}

/// A cluster master's STATE for the demo frame (encode_frame_state: the skeleton's record, the
/// console's, the frame's, each zlib-packed and checksummed), per frame: arg 0 without the
/// console record; arg 1 with it (the console made once); arg 2 the master's path, the console
/// made for the frame (Installation::console()) and encoded. `bytes`: the STATE's payload.
void BM_ClusterStateEncodeDemo(benchmark::State& state) {
  const DemoFighter demo = demo_state();
  const FrameData& f = *demo.frame;
  const ConsoleState console = demo.inst->console(f);
  if (console.planner.empty() || !f.fighter.present) {
    state.SkipWithError("the demo frame has no fighter or no planner line (no demo data?)");
    return;
  }
  std::string out;
  for (auto _ : state) {
    if (state.range(0) == 0) {
      encode_frame_state(f, true, nullptr, out, kFrameVersion);
    } else if (state.range(0) == 1) {
      encode_frame_state(f, console, out);
    } else {
      encode_frame_state(f, demo.inst->console(f), out);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["bytes"] = static_cast<double>(out.size());
  state.counters["events"] = static_cast<double>(f.events.size());
  state.counters["recent"] = static_cast<double>(console.recent.size());
}
BENCHMARK(BM_ClusterStateEncodeDemo)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond);

/// A render node's side: the same STATE decoded (FrameStateDecoder, the skeleton kept from the
/// first), arg 0 without the console record, arg 1 with it (read and checked into a console).
void BM_ClusterStateDecodeDemo(benchmark::State& state) {
  const DemoFighter demo = demo_state();
  const FrameData& f = *demo.frame;
  const ConsoleState console = demo.inst->console(f);
  std::string bytes;
  if (state.range(0) == 0)
    encode_frame_state(f, true, nullptr, bytes, kFrameVersion);
  else
    encode_frame_state(f, console, bytes);
  FrameStateDecoder decoder;
  FrameData got;
  ConsoleState got_console;
  if (!decoder.decode(bytes, got, &got_console) || decoder.has_console() != (state.range(0) == 1) ||
      (state.range(0) == 1 && got_console.planner != console.planner)) {
    state.SkipWithError(("the demo's STATE does not read back: " + decoder.problem() + decoder.console_problem()).c_str());
    return;
  }
  for (auto _ : state) {
    const bool ok = decoder.decode(bytes, got, state.range(0) == 1 ? &got_console : nullptr);
    benchmark::DoNotOptimize(ok);
    benchmark::DoNotOptimize(got.fighter.joints.data());
  }
  state.counters["bytes"] = static_cast<double>(bytes.size());
}
BENCHMARK(BM_ClusterStateDecodeDemo)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
