// Google Benchmark: many worlds a frame at a time (decision 0103) — world-frames per second of
// haustra::Batch on 1 and 2 threads against a loop stepping each world in turn, for N = 1 … 1,000
// worlds of a small rod (21 nodes under gravity, lagged, world.threads = 1: a rollout's world).
// The Python loop against haustra.Batch is python/tools/bench_batch.py (`make bench` runs both).
#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "haustra/batch.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"

namespace {

using namespace haustra;

constexpr int kFrames = 10;  // per world and iteration

constexpr const char* kRolloutScene = R"(
[scene]
name = "rollout"
[world]
dt = 0.01
threads = 1
gravity = [0.0, 0.0, -9.81]
[[segment]]
name = "rod"
nodes = 21
youngs_modulus = 1000000.0
[segment.rest]
length = 1.0
)";

std::vector<std::unique_ptr<World>> make_worlds(std::size_t count) {
  const SceneDesc scene = parse_scene(kRolloutScene, "bench_batch.toml");
  std::vector<std::unique_ptr<World>> worlds;
  for (std::size_t i = 0; i < count; ++i) worlds.push_back(create_world(scene));
  return worlds;
}

void report(benchmark::State& state, std::size_t worlds) {
  const auto frames = static_cast<double>(state.iterations()) * static_cast<double>(worlds) * kFrames;
  state.SetItemsProcessed(static_cast<std::int64_t>(frames));
  state.counters["world_frames_per_second"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
  state.counters["worlds"] = static_cast<double>(worlds);
}

// Args: worlds, threads.
void BM_Batch(benchmark::State& state) {
  const auto count = static_cast<std::size_t>(state.range(0));
  auto owned = make_worlds(count);
  std::vector<World*> worlds;
  for (auto& w : owned) worlds.push_back(w.get());
  Batch batch(static_cast<int>(state.range(1)));
  std::vector<Batch::Outcome> outcomes(count);
  for (auto _ : state) {
    batch.step(worlds, kFrames, outcomes);
    benchmark::DoNotOptimize(outcomes.data());
  }
  report(state, count);
}
BENCHMARK(BM_Batch)
    ->ArgNames({"worlds", "threads"})
    ->ArgsProduct({{1, 10, 100, 1000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The same worlds stepped one after another, a frame each in turn, by a loop in C++.
void BM_Loop(benchmark::State& state) {
  const auto count = static_cast<std::size_t>(state.range(0));
  auto worlds = make_worlds(count);
  for (auto _ : state) {
    for (int f = 0; f < kFrames; ++f)
      for (auto& w : worlds) w->step();
  }
  report(state, count);
}
BENCHMARK(BM_Loop)
    ->ArgNames({"worlds"})
    ->Arg(1)
    ->Arg(10)
    ->Arg(100)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
