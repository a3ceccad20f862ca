// Google Benchmark: the whole organs of the anatomy atlas (tests/data/anatomy), imported with the
// defaults at start-up, stepped with their meshes on 1 and 2 threads — the whole small intestine's
// frame rate against the 60 frames a second a screen needs (issue 24); and the whole abdomen of one
// body at the haptic rate, frame by frame (issue 40).
#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "haustra/frame_publisher.hpp"
#include "haustra/import/import.hpp"
#include "haustra/profile.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/anatomy_cohort.hpp"
#include "haustra/world.hpp"

namespace {

using namespace haustra;
namespace fs = std::filesystem;

const char* const kOrgans[] = {"HuBMAPVHM-00070-small-intestine", "HuBMAPVHM-00070-large-intestine"};

// Each organ imported once per run, into the temporary folder.
const SceneDesc& imported(int organ) {
  static std::map<int, SceneDesc> scenes;
  auto it = scenes.find(organ);
  if (it != scenes.end()) return it->second;
  import::ImportOptions o;
  o.mesh = fs::path(HAUSTRA_SOURCE_DIR) / "tests" / "data" / "anatomy" / (std::string(kOrgans[organ]) + ".obj");
  o.out = fs::temp_directory_path() / "haustra-bench-anatomy" / kOrgans[organ] / "scene.toml";
  return scenes.emplace(organ, load_scene(import::import_surface(o).scene)).first->second;
}

void BM_WholeOrgan(benchmark::State& state) {
  SceneDesc scene = imported(static_cast<int>(state.range(0)));
  scene.world.threads = static_cast<int>(state.range(1));
  auto w = create_world(scene);
  for (int f = 0; f < 3; ++f) w->step();
  for (auto _ : state) w->step();
  state.SetLabel(kOrgans[state.range(0)]);
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["nodes"] = static_cast<double>(w->node_count());
  state.counters["vertices"] = static_cast<double>(w->mesh_buffer_size());
}

// The abdomen of `make anatomy` (EdinGCA-00020: the large intestine's ten surfaces and the terminal
// ileum, in their body, held by their tissue; decisions 0094, 0095), read from HAUSTRA_ANATOMY_DATA
// (default ../shared/data beside the source tree: anatomy/ and body/), imported once.
const SceneDesc* abdomen(std::string& why) {
  static std::unique_ptr<SceneDesc> scene;
  static std::string error;
  if (scene || !error.empty()) return why = error, scene.get();
  const char* env = std::getenv("HAUSTRA_ANATOMY_DATA");
  const fs::path data = env != nullptr ? fs::path(env) : fs::path(HAUSTRA_SOURCE_DIR) / ".." / "shared" / "data";
  const fs::path body = data / "body" / "EdinGCA-00020-body.obj";
  std::vector<fs::path> surfaces;
  if (fs::is_directory(data / "anatomy"))
    for (const auto& e : fs::directory_iterator(data / "anatomy"))
      if (e.path().extension() == ".obj" && e.path().filename().string().starts_with("EdinGCA-00020"))
        surfaces.push_back(e.path());
  std::sort(surfaces.begin(), surfaces.end());
  if (surfaces.empty() || !fs::exists(body)) {
    error = "no EdinGCA-00020 surfaces or body under " + data.string() + " (set HAUSTRA_ANATOMY_DATA)";
    return why = error, nullptr;
  }
  import::ImportOptions o;
  o.mesh = surfaces.front();
  o.more_meshes.assign(surfaces.begin() + 1, surfaces.end());
  o.body = body;
  o.out = fs::temp_directory_path() / "haustra-bench-abdomen" / "abdomen.toml";
  fs::create_directories(o.out.parent_path());
  scene = std::make_unique<SceneDesc>(load_scene(import::import_surfaces(o).scene));
  return scene.get();
}

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(i, v.size() - 1)];
}

// Where the sigmoid colon lies along the large intestine (the abdomen's longest organ, a fraction of
// its nodes from its base): at its node nearest the middle of the A-DSJ surface's centreline (anus to
// the descending–sigmoid junction, 755 mm; its first 15 cm are the rectum, so its middle is sigmoid).
// The import keeps the data's frame (mm → m), so the source centreline locates it. 0.5 if absent.
double sigmoid_along(const SceneDesc& scene) {
  const char* env = std::getenv("HAUSTRA_ANATOMY_DATA");
  const fs::path data = env != nullptr ? fs::path(env) : fs::path(HAUSTRA_SOURCE_DIR) / ".." / "shared" / "data";
  std::ifstream in(data / "anatomy" / "EdinGCA-00020-large-intestine-A-DSJ-centreline.json");
  if (!in) return 0.5;
  std::vector<Eigen::Vector3d> p;
  const nlohmann::json centreline = nlohmann::json::parse(in);
  for (const auto& q : centreline.at("points"))
    p.emplace_back(1e-3 * q[0].get<double>(), 1e-3 * q[1].get<double>(), 1e-3 * q[2].get<double>());
  double half = 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) half += 0.5 * (p[i] - p[i - 1]).norm();
  Eigen::Vector3d middle = p.back();
  for (std::size_t i = 1; i < p.size(); ++i) {
    const double l = (p[i] - p[i - 1]).norm();
    if (l >= half) {
      middle = p[i - 1] + half / l * (p[i] - p[i - 1]);
      break;
    }
    half -= l;
  }
  SceneDesc alone = scene;
  alone.world.threads = 1;
  const auto w = create_world(alone);
  const auto x = w->node_positions();
  const auto organ = w->segment(0).nodes;  // the large intestine's chain: the import's first organ
  std::size_t last = 0;
  while (last + 1 < w->segment_count() && w->chain_of(last + 1) == 0) ++last;
  const std::size_t count = w->segment(last).nodes.offset + w->segment(last).nodes.count - organ.offset;
  std::size_t nearest = 0;
  for (std::size_t k = 1; k < count; ++k)
    if ((x.get(organ.offset + k) - middle).norm() < (x.get(organ.offset + nearest) - middle).norm()) nearest = k;
  return static_cast<double>(nearest) / static_cast<double>(count - 1);
}

// Issue 40's abdomen at 1 kHz: the organ protocol's grasper (decision 0097) on the sigmoid colon of
// the longest organ (the large intestine, sigmoid_along), coming down from 0.05 s, closing at 0.55 s and pulling 5 cm
// sideways until 1.55 s, held to 1.75 s; on 2 threads; solver 2 fast mode, 0 Newton. The mesh is
// made when read (decision 0060). reader 0: never read; reader 1: a render thread that skins on its
// GPU (decision 0110) acquires the newest frame's rings every 1/60 s of wall time while the physics
// steps and publishes beside it. sleep 1: rods at rest and untouched sleep (decision 0119); sleep 2: ranges within them
// too (decision 0127). Each iteration is one physics frame with its publish, timed by hand; the counters are ms.
void BM_Abdomen(benchmark::State& state) {
  std::string why;
  const SceneDesc* imported = abdomen(why);
  if (imported == nullptr) {
    state.SkipWithError(why.c_str());
    return;
  }
  import::OrganProtocol protocol;
  protocol.rest = 0.05;
  protocol.pull = 1.0;
  protocol.hold = 0.2;
  static const double along = sigmoid_along(*imported);
  protocol.along = along;
  SceneDesc scene = import::with_protocol_grasper(*imported, protocol);
  scene.world.dt = 1e-3;
  scene.world.threads = 2;
  scene.world.mesh_update = MeshUpdate::on_read;
  scene.world.solver.mode = state.range(0) == 2 ? SolverMode::fast : SolverMode::newton;
  scene.world.sleep.enabled = state.range(2) >= 1;
  scene.world.sleep.ranges = state.range(2) == 2;
  auto w = create_world(scene);
  FramePublisher frames(*w);
  frames.skin_on_gpu(true);
  std::atomic<bool> stop{false};
  std::atomic<int> reads{0};
  std::thread render;
  if (state.range(1) == 1)
    render = std::thread([&] {
      while (!stop.load()) {
        benchmark::DoNotOptimize(frames.acquire().gpu_rings.data());
        frames.release();
        reads.fetch_add(1);
        std::this_thread::sleep_for(std::chrono::microseconds(16'667));
      }
    });
  std::vector<double> seconds;
  seconds.reserve(static_cast<std::size_t>(state.max_iterations));
  std::array<double, kStageCount> stage_seconds{};  // the stage table: each stage's own time, summed
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    w->step();
    frames.publish(*w);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(s);
    seconds.push_back(s);
    for (std::size_t k = 0; k < kStageCount; ++k) stage_seconds[k] += w->last_profile().seconds[k];
  }
  for (std::size_t k = 0; k < kStageCount; ++k)
    if (stage_seconds[k] > 0.0)
      state.counters[fmt::format("stage {} us", stage_name(static_cast<Stage>(k)))] =
          1e6 * stage_seconds[k] / static_cast<double>(seconds.size());
  stop.store(true);
  if (render.joinable()) render.join();
  state.counters["render reads"] = reads.load();
  state.counters["median ms"] = 1e3 * quantile(seconds, 0.5);
  state.counters["p99 ms"] = 1e3 * quantile(seconds, 0.99);
  state.counters["p99.9 ms"] = 1e3 * quantile(seconds, 0.999);
  state.counters["max ms"] = 1e3 * quantile(seconds, 1.0);
  state.counters["nodes"] = static_cast<double>(w->node_count());
  state.counters["nodes asleep at the end"] = w->last_profile().nodes_asleep;
  state.counters["beads"] = static_cast<double>(w->bead_count());
  state.counters["grasped at (fraction along the large intestine)"] = along;
  state.counters["grasping"] = w->instrument(w->instrument_count() - 1).grasping ? 1.0 : 0.0;  // at the end: holding
}

}  // namespace

BENCHMARK(BM_Abdomen)
    ->Args({2, 0, 0})
    ->Args({2, 0, 1})
    ->Args({2, 0, 2})
    ->Args({2, 1, 0})
    ->Args({2, 1, 1})
    ->Args({2, 1, 2})
    ->Args({0, 0, 0})
    ->ArgNames({"solver", "reader", "sleep"})
    ->Iterations(1750)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_WholeOrgan)
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->ArgNames({"organ", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();
BENCHMARK_MAIN();
