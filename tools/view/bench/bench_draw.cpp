// The viewer's draw rate (issue 39): one window frame's geometry built from a published frame and
// drawn to a hidden 1280x720 window, glFinish included, for the demo and the 300k-vertex small
// intestine. Run under a display (make bench-view starts Xvfb when there is none); the counter
// `draws_per_second` is what the window reaches when drawing is all it does.
#include <GLFW/glfw3.h>
#include <benchmark/benchmark.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "../src/gl_scene.hpp"
#include "../src/simulation.hpp"
#include "haustra/scene.hpp"

namespace {

using namespace haustra;
using namespace haustra::view;

struct Window {
  GLFWwindow* window = nullptr;
  Window(int samples) {
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_SAMPLES, samples);
    glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
    window = glfwCreateWindow(1280, 720, "bench", nullptr, nullptr);
    if (window == nullptr) throw std::runtime_error("no OpenGL 3.3 window");
    glfwMakeContextCurrent(window);
  }
  ~Window() { glfwDestroyWindow(window); }
};

// One window frame: geometry from the latest frame, drawn and finished. range(0): samples (MSAA).
void draw_scene(benchmark::State& state, const std::string& scene_file) {
  Window window(static_cast<int>(state.range(0)));
  Simulation sim(load_scene(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/" + scene_file, {}), 2, "", false, true);
  sim.start();
  sim.step_in_lockstep(20);  // settled into its first frames, the grasper on its way
  std::shared_ptr<const ModelInfo> model;
  OrbitCamera camera;
  DrawOptions options;
  {
    GlScene scene;
    const FramePublisher::Slot& f = sim.frames().acquire();
    model = sim.model();
    scene.build(f, *model, options, camera);
    sim.frames().release();
  }
  GlScene scene;
  bool fitted = false;
  for (auto _ : state) {
    const FramePublisher::Slot& f = sim.frames().acquire();
    scene.build(f, *model, options, camera);
    if (!fitted) {
      camera.fit(scene.subject_lo(), scene.subject_hi());
      fitted = true;
    }
    sim.frames().release();
    scene.draw(camera, options, 1280, 720);
    glFinish();
  }
  state.counters["draws_per_second"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["mesh_vertices"] = static_cast<double>(model->vertex_node.size());
  state.counters["triangles"] = static_cast<double>(model->triangles.size());
  state.counters["drawn"] = static_cast<double>(scene.organ_triangles_drawn());
}

void BM_DrawDemo(benchmark::State& state) { draw_scene(state, "demo.toml"); }
void BM_DrawSmallIntestine(benchmark::State& state) { draw_scene(state, "small-intestine.toml"); }

BENCHMARK(BM_DrawDemo)->Arg(0)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(2.0);
BENCHMARK(BM_DrawSmallIntestine)->Arg(0)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(4.0);

}  // namespace

int main(int argc, char** argv) {
  if (glfwInit() == GLFW_FALSE) {
    std::fprintf(stderr, "haustra_bench_view: no display (run under xvfb-run, or make bench-view)\n");
    return 2;
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  glfwTerminate();
  return 0;
}
