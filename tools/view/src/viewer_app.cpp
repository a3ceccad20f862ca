// The window: GLFW + OpenGL 3.3 core + Dear ImGui. Each window frame takes the latest published
// simulation frame, builds and draws it, runs the panels and the script, and never waits for a step.
#include "viewer_app.hpp"

#define GL_GLEXT_PROTOTYPES 1
#define GLFW_INCLUDE_GLCOREARB 1
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "gl_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/render/image.hpp"
#include "haustra/scene.hpp"
#include "mouse.hpp"
#include "panels.hpp"
#include "script_player.hpp"
#include "simulation.hpp"

namespace haustra::view {
namespace {

constexpr int kExitBadInput = 2;
constexpr int kExitUnstable = 3;

std::string g_glfw_error;  // the last GLFW error, for the message when no window opens

ViewerState& state_of(GLFWwindow* w) { return *static_cast<ViewerState*>(glfwGetWindowUserPointer(w)); }
bool imgui_has_mouse() { return ImGui::GetIO().WantCaptureMouse; }

void install_input(GLFWwindow* window) {
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int mods) {
    ViewerState& v = state_of(w);
    const Button b = button == GLFW_MOUSE_BUTTON_RIGHT    ? Button::right
                     : button == GLFW_MOUSE_BUTTON_MIDDLE ? Button::middle
                                                          : Button::left;
    v.mouse.ctrl = (mods & GLFW_MOD_CONTROL) != 0;
    v.mouse.shift = (mods & GLFW_MOD_SHIFT) != 0;
    if (action == GLFW_PRESS && !imgui_has_mouse()) mouse_press(v, b, v.mouse.x, v.mouse.y);
    if (action == GLFW_RELEASE) mouse_release(v, b);
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) { mouse_move(state_of(w), x, y); });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    if (!imgui_has_mouse()) mouse_scroll(state_of(w), dy);
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int mods) {
    ViewerState& v = state_of(w);
    v.mouse.ctrl = (mods & GLFW_MOD_CONTROL) != 0 || (key == GLFW_KEY_LEFT_CONTROL && action != GLFW_RELEASE);
    if (action != GLFW_PRESS || ImGui::GetIO().WantCaptureKeyboard) return;
    if (key == GLFW_KEY_SPACE) v.sim.post(SetPaused{!v.sim.stats().paused});
    if (key == GLFW_KEY_RIGHT) v.sim.post(StepOnce{});
    if (key == GLFW_KEY_TAB) v.show_panels = !v.show_panels;
    if (key == GLFW_KEY_B) v.draw.beads = !v.draw.beads;
    if (key == GLFW_KEY_T) v.draw.anchors = !v.draw.anchors;
    if (key == GLFW_KEY_F) v.camera_fitted = false;  // fit the camera to the organ again
    if (key == GLFW_KEY_ESCAPE) glfwSetWindowShouldClose(w, GLFW_TRUE);
  });
}

// Copies what the window needs from the newest frame and builds its geometry; the slot is held
// only for this.
void take_frame(ViewerState& v, GlScene& scene) {
  FramePublisher& frames = v.sim.frames();
  const FramePublisher::Slot& f = frames.acquire();
  v.model = v.sim.model();  // matches the slot: a rebuild waits for the release below
  const ModelInfo& m = *v.model;
  const bool fresh = f.frame != v.frame || v.bead_centres.empty();
  v.frame = f.frame;
  v.time = f.time;
  v.profile = f.details.profile;
  v.instruments = f.details.instruments;
  v.contact_count = f.details.contacts.size();
  v.bead_centres.resize(m.bead_nodes.size());
  for (std::size_t i = 0; i < m.bead_nodes.size(); ++i) {
    const std::size_t k = m.bead_nodes[i];
    v.bead_centres[i] = {f.x[k], f.y[k], f.z[k]};
  }
  if (!v.camera_fitted && !f.x.empty()) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
    for (std::size_t k = 0; k < f.x.size(); ++k) {
      lo = lo.cwiseMin(Eigen::Vector3d(f.x[k], f.y[k], f.z[k]));
      hi = hi.cwiseMax(Eigen::Vector3d(f.x[k], f.y[k], f.z[k]));
    }
    v.camera.fit(lo, hi);
    if (v.show_panels) v.camera.pan(0.5 * kPanelWidth, 0.0);  // the subject in the middle of what the panel leaves
    v.camera_fitted = true;
  }
  if (fresh) {
    v.plots.resize(std::min(m.mouse, v.instruments.size()));
    for (std::size_t i = 0; i < v.plots.size(); ++i)
      v.plots[i].push(static_cast<float>(v.instruments[i].force.norm()),
                      static_cast<float>(v.instruments[i].filtered_force.norm()));
  }
  if (fresh && m.mouse < v.instruments.size()) {
    const InstrumentReading& r = v.instruments[m.mouse];
    v.plot.push(static_cast<float>(r.force.norm()), static_cast<float>(r.filtered_force.norm()));
    if (v.recording) {
      Sample s{f.frame, f.time, r.grasping, 0, Eigen::Vector3d::Zero(), r.tip, r.force, r.filtered_force, 0};
      for (const std::uint8_t intact : f.details.anchors_intact) s.anchors_cut += intact == 0 ? 1 : 0;
      if (r.grasping && r.grasped_segment < m.segment_nodes.size()) {
        s.node = m.segment_nodes[r.grasped_segment].offset + r.grasped_node;
        s.node_position = {f.x[s.node], f.y[s.node], f.z[s.node]};
      }
      v.samples.push_back(s);
    }
  }
  scene.build(f, m, v.draw);
  frames.release();
}

void save_screenshot(const std::string& path, int width, int height) {
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(3 * width * height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, rgb.data());
  std::vector<std::uint8_t> top_down(rgb.size());  // GL's rows start at the bottom
  const std::size_t row = static_cast<std::size_t>(3 * width);
  for (int y = 0; y < height; ++y)
    std::copy_n(rgb.begin() + static_cast<std::ptrdiff_t>(row * static_cast<std::size_t>(height - 1 - y)), row,
                top_down.begin() + static_cast<std::ptrdiff_t>(row * static_cast<std::size_t>(y)));
  if (const auto dir = std::filesystem::path(path).parent_path(); !dir.empty())
    std::filesystem::create_directories(dir);
  render::Image::from_srgb8(width, height, top_down).save_png(path);
}

nlohmann::json vec(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

void write_record(const ViewerState& v, const std::string& path) {
  nlohmann::json j;
  j["scene"] = v.scene_name;
  j["frames"] = v.frame;
  j["unstable"] = v.sim.went_unstable();
  for (const Sample& s : v.samples)
    j["samples"].push_back({{"frame", s.frame},
                            {"time", s.time},
                            {"grasping", s.grasping},
                            {"node", s.node},
                            {"node_position", vec(s.node_position)},
                            {"tip", vec(s.tip)},
                            {"force", vec(s.force)},
                            {"filtered_force", vec(s.filtered_force)},
                            {"anchors_cut", s.anchors_cut}});
  for (const InputEvent& e : v.events) {
    const OrbitCamera& c = e.camera;
    j["events"].push_back({{"kind", e.kind},
                           {"frame", e.frame},
                           {"x", e.x},
                           {"y", e.y},
                           {"on_organ", e.on_organ},
                           {"bead", e.bead},
                           {"hit", vec(e.hit)},
                           {"camera",
                            {{"eye", vec(c.eye())},
                             {"target", vec(c.target)},
                             {"fov_degrees", c.fov_degrees},
                             {"width", c.width},
                             {"height", c.height}}}});
  }
  j["plot"]["raw"] = std::vector<float>(v.plot.raw.begin(), v.plot.raw.end());
  j["plot"]["filtered"] = std::vector<float>(v.plot.filtered.begin(), v.plot.filtered.end());
  j["screenshots"] = v.screenshots;
  j["log"] = v.log;
  std::ofstream out(path);
  out << j.dump(1) << "\n";
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write the record", path));
}

struct GlfwSession {
  GlfwSession() {
    glfwSetErrorCallback([](int, const char* description) { g_glfw_error = description; });
    if (glfwInit() == GLFW_FALSE)
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("no display: {} (run on a desktop, or under xvfb-run)", g_glfw_error));
  }
  ~GlfwSession() { glfwTerminate(); }
};

GLFWwindow* open_window(const ViewerOptions& o, const std::string& title) {
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SAMPLES, 4);
  GLFWwindow* w = glfwCreateWindow(o.width, o.height, title.c_str(), nullptr, nullptr);
  if (w == nullptr)
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("no window with OpenGL 3.3: {} (run on a desktop, or under xvfb-run with Mesa)", g_glfw_error));
  glfwMakeContextCurrent(w);
  glfwSwapInterval(1);
  return w;
}

int loop(ViewerState& v, GLFWwindow* window, std::optional<ScriptPlayer>& script, const ViewerOptions& o) {
  GlScene scene;
  const auto frame_budget = std::chrono::microseconds(16'000);  // ~60 Hz: the other core is the physics'
  while (glfwWindowShouldClose(window) == GLFW_FALSE && !v.quit) {
    const auto started = std::chrono::steady_clock::now();
    glfwPollEvents();
    if (script) v.sim.step_in_lockstep();  // a frame of physics per window frame, whatever the load
    for (std::string& line : v.sim.take_log()) v.note(std::move(line));
    if (script && !script->tick(v)) v.quit = true;
    if (!script && !o.screenshot.empty() && v.frame >= static_cast<std::uint64_t>(v.scene_frames)) v.quit = true;
    int fbw = 0, fbh = 0, ww = 0, wh = 0;
    glfwGetFramebufferSize(window, &fbw, &fbh);
    glfwGetWindowSize(window, &ww, &wh);
    v.camera.width = std::max(ww, 1);
    v.camera.height = std::max(wh, 1);
    take_frame(v, scene);
    scene.draw(v.camera, v.draw, fbw, fbh);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    draw_panels(v);
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (!v.screenshot_pending.empty()) {
      save_screenshot(v.screenshot_pending, fbw, fbh);
      v.screenshots.push_back(v.screenshot_pending);
      v.screenshot_pending.clear();
    }
    if (v.quit && !o.screenshot.empty()) save_screenshot(o.screenshot, fbw, fbh);
    glfwSwapBuffers(window);
    if (!script) std::this_thread::sleep_until(started + frame_budget);
  }
  return script && v.sim.went_unstable() ? kExitUnstable : 0;
}

}  // namespace

int run_viewer(const ViewerOptions& o) {
  // The scene first: a scene that does not load fails as `haustra run` fails, display or not.
  const SceneDesc scene = load_scene(o.scene, o.sets);
  std::optional<ScriptPlayer> script;
  if (!o.script.empty()) script.emplace(read_script(o.script));
  Simulation sim(scene, o.threads, o.checkpoint, o.paused, /*lockstep=*/script.has_value());
  GlfwSession glfw;
  GLFWwindow* window = open_window(o, fmt::format("haustra view - {}", scene.name));
  ViewerState v(sim);
  v.scene_name = scene.name;
  v.scene_dt = scene.world.dt;
  v.scene_frames = scene.frames;
  v.recording = !o.record.empty();
  glfwSetWindowUserPointer(window, &v);
  install_input(window);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini left in the working directory
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window, true);  // chains to the callbacks installed above
  ImGui_ImplOpenGL3_Init("#version 330 core");
  sim.start();
  int code = 0;
  try {
    code = loop(v, window, script, o);
  } catch (...) {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window);
    throw;
  }
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  if (!o.record.empty()) write_record(v, o.record);
  return code;
}

}  // namespace haustra::view
