// Google Benchmark: the whole organs of the anatomy atlas (tests/data/anatomy), imported with the
// defaults at start-up, stepped with their meshes on 1 and 2 threads — the whole small intestine's
// frame rate against the 60 frames a second a screen needs (issue 24).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "haustra/import/import.hpp"
#include "haustra/scene.hpp"
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

}  // namespace

BENCHMARK(BM_WholeOrgan)
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->ArgNames({"organ", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();
BENCHMARK_MAIN();
