// Google Benchmark: issue 29's whole small intestine at the haptic rate, frame by frame: the
// physics frame's median and tail (p99, p99.9, max), fast mode and Newton, two threads.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

#include "haustra/frame_publisher.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace {

using namespace haustra;
using Clock = std::chrono::steady_clock;

constexpr int kSettleFrames = 100;  // the first 0.1 s: the pile settling onto the floor
constexpr int kRenderEvery = 17;    // a 60 Hz reader beside 1 kHz physics
constexpr double kHapticBudget = 1e-3;

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

// Args: solver (0 Newton with the scene's 2 iterations, 2 fast mode); mesh (0: made when read, a
// 60 Hz reader acquiring every 17th frame through a FramePublisher, in lockstep on this thread
// and outside the frame's time; 1: skinned at the end of every frame, as before decision 0060).
// Each iteration is one physics frame (with its publish), timed by hand; the counters are ms.
void BM_SmallIntestine(benchmark::State& state) {
  std::vector<std::string> sets{"world.threads=2"};
  sets.emplace_back(state.range(0) == 2 ? "solver.mode=fast" : "solver.mode=newton");
  sets.emplace_back(state.range(1) == 1 ? "world.mesh_update=every_frame" : "world.mesh_update=on_read");
  SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/small-intestine.toml", sets);
  scene.world.frame_budget = kHapticBudget;
  const Clock::time_point built0 = Clock::now();
  std::unique_ptr<World> w = create_world(scene);
  const double build_seconds = std::chrono::duration<double>(Clock::now() - built0).count();
  FramePublisher frames(*w);
  for (int f = 0; f < kSettleFrames; ++f) w->step();
  const std::uint64_t late_before = w->late_frames();
  std::vector<double> seconds, render_seconds;
  seconds.reserve(static_cast<std::size_t>(state.max_iterations));
  for (auto _ : state) {
    const Clock::time_point t0 = Clock::now();
    w->step();
    frames.publish(*w);
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    state.SetIterationTime(s);
    seconds.push_back(s);
    if (seconds.size() % kRenderEvery == 0) {
      const Clock::time_point r0 = Clock::now();
      benchmark::DoNotOptimize(frames.acquire().px.data());
      frames.release();
      render_seconds.push_back(std::chrono::duration<double>(Clock::now() - r0).count());
    }
  }
  state.counters["median ms"] = 1e3 * quantile(seconds, 0.5);
  state.counters["p99 ms"] = 1e3 * quantile(seconds, 0.99);
  state.counters["p99.9 ms"] = 1e3 * quantile(seconds, 0.999);
  state.counters["max ms"] = 1e3 * quantile(seconds, 1.0);
  state.counters["late frames"] = static_cast<double>(w->late_frames() - late_before);
  state.counters["reader acquire ms"] = render_seconds.empty() ? 0.0 : 1e3 * quantile(render_seconds, 0.5);
  state.counters["build s"] = build_seconds;
  state.counters["nodes"] = static_cast<double>(w->node_count());
  state.counters["mesh vertices"] = static_cast<double>(w->mesh_buffer_size());
}

// The render thread's share of a frame of the 6 m small intestine (decision 0110): a reader that
// draws the CPU's mesh (gpu:0: acquire skins 300k vertices and their normals, along the rod, the
// default) or skins on its GPU (gpu:1: acquire makes the rings' data for the shader alone), or draws
// the CPU's mesh skinned by the cage (gpu:2, decision 0120: the ratio of gpu:0 to it in one run is
// the default skin's cost against the cage's). Each iteration steps and publishes a frame untimed,
// then times the acquire.
void BM_SmallIntestineReader(benchmark::State& state) {
  const bool gpu = state.range(0) == 1;
  std::vector<std::string> sets{"world.threads=2"};
  if (state.range(0) == 2) sets.emplace_back("segment.mesh.skinning=cage");
  SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/small-intestine.toml", sets);
  std::unique_ptr<World> w = create_world(scene);
  FramePublisher frames(*w);
  frames.skin_on_gpu(gpu);
  for (int f = 0; f < kSettleFrames; ++f) w->step();
  std::vector<double> seconds;
  for (auto _ : state) {
    w->step();
    frames.publish(*w);
    const Clock::time_point r0 = Clock::now();
    const FramePublisher::Slot& s = frames.acquire();
    benchmark::DoNotOptimize(gpu ? s.gpu_rings.data() : s.px.data());
    frames.release();
    seconds.push_back(std::chrono::duration<double>(Clock::now() - r0).count());
    state.SetIterationTime(seconds.back());
  }
  state.counters["acquire ms"] = 1e3 * quantile(seconds, 0.5);
  state.counters["mesh vertices"] = static_cast<double>(w->mesh_buffer_size());
  state.counters["rings"] = static_cast<double>(w->ring_count());
  state.counters["bytes to the GPU a frame"] = static_cast<double>(
      gpu ? haustra::kGpuRingFloats * w->ring_count() * sizeof(float) : 6 * w->mesh_buffer_size() * sizeof(float));
}

// Each iteration: a fresh world of `scene` stepped `first` frames untimed, then `frames` frames each
// timed by hand; after_frame(world) sees each timed frame. The seconds of every timed frame.
template <class F>
std::vector<double> time_frames(benchmark::State& state, const SceneDesc& scene, int first, int frames,
                                F&& after_frame) {
  std::vector<double> seconds;
  for (auto _ : state) {
    state.PauseTiming();
    const std::unique_ptr<World> w = create_world(scene);
    for (int f = 0; f < first; ++f) w->step();
    state.ResumeTiming();
    for (int f = 0; f < frames; ++f) {
      const Clock::time_point t0 = Clock::now();
      w->step();
      seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
      after_frame(*w);
    }
  }
  return seconds;
}

// Issue 29's `bowel` (641 nodes, one chained rod split over two cores, decision 0040), Newton with
// the scene's 2 iterations, on `threads` threads: frames 60–300 (the grasp and the draw), each
// timed by hand, its mesh made when read and never read. The 1 → 2 thread ratio of the medians is
// the target.
void BM_Bowel(benchmark::State& state) {
  const std::vector<std::string> sets{"world.threads=" + std::to_string(state.range(0)), "world.mesh_update=on_read"};
  const SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/bowel.toml", sets);
  std::size_t nodes = 0;
  const std::vector<double> seconds =
      time_frames(state, scene, 60, 240, [&](const World& w) { nodes = w.node_count(); });
  state.counters["median ms"] = 1e3 * quantile(seconds, 0.5);
  state.counters["p99 ms"] = 1e3 * quantile(seconds, 0.99);
  state.counters["nodes"] = static_cast<double>(nodes);
}

// Issue 40's settling pile (scenes/settling-pile.toml: the 6 m small intestine folded and let fall
// onto a floor, no drag, no mesh, fast mode, 2 threads): frames 100–300 while it settles, each timed
// by hand. Its first touch makes the robust mode redo a frame with 2 substeps; "frames on a climbed
// rung" counts the timed frames that still run it (decision 0109).
void BM_SettlingPile(benchmark::State& state) {
  const SceneDesc scene = load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/settling-pile.toml");
  int climbed = 0;
  const std::vector<double> seconds =
      time_frames(state, scene, 100, 200, [&](const World& w) { climbed += w.last_profile().substeps > 1 ? 1 : 0; });
  state.counters["median ms"] = 1e3 * quantile(seconds, 0.5);
  state.counters["p99 ms"] = 1e3 * quantile(seconds, 0.99);
  state.counters["p99.9 ms"] = 1e3 * quantile(seconds, 0.999);
  state.counters["max ms"] = 1e3 * quantile(seconds, 1.0);
  state.counters["frames on a climbed rung"] = climbed;
  state.counters["frames"] = static_cast<double>(seconds.size());
}

}  // namespace

BENCHMARK(BM_SettlingPile)->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SmallIntestineReader)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->ArgNames({"gpu"})
    ->Iterations(200)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Bowel)->Arg(1)->Arg(2)->ArgNames({"threads"})->Iterations(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SmallIntestine)
    ->ArgsProduct({{2, 0}, {0, 1}})
    ->ArgNames({"solver", "mesh_every_frame"})
    ->Iterations(1200)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
