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

#include "actions.hpp"
#include "gl_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "inspector.hpp"
#include "menus.hpp"
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

}  // namespace

// A key pressed (GLFW's codes), by a person or a script: the help overlay lists them all.
void press_key(ViewerState& v, int key, int mods, int width, int height) {
  const bool ctrl = (mods & GLFW_MOD_CONTROL) != 0;
  switch (key) {
    case GLFW_KEY_SPACE: v.sim.post(SetPaused{!v.sim.stats().paused}); break;
    case GLFW_KEY_RIGHT: v.sim.post(StepOnce{}); break;
    case GLFW_KEY_TAB: v.show_panels = !v.show_panels; break;
    case GLFW_KEY_I: v.inspector_open = !v.inspector_open; break;
    case GLFW_KEY_B: v.draw.beads = !v.draw.beads; break;
    case GLFW_KEY_T: v.draw.anchors = !v.draw.anchors; break;
    case GLFW_KEY_K: v.draw.gpu_skinning = !v.draw.gpu_skinning; break;
    case GLFW_KEY_F: v.camera_fitted = false; break;  // fit the camera to the organ again
    case GLFW_KEY_G: v.follow = !v.follow; break;
    case GLFW_KEY_1: set_view(v, View::front); break;
    case GLFW_KEY_2: set_view(v, View::top); break;
    case GLFW_KEY_3: set_view(v, View::side); break;
    case GLFW_KEY_0: set_view(v, View::standard); break;
    case GLFW_KEY_P: v.note("screenshot " + take_screenshot(v)); break;
    case GLFW_KEY_V: v.note(toggle_video(v, width, height)); break;
    case GLFW_KEY_F1:
    case GLFW_KEY_H: v.help_open = !v.help_open; break;
    case GLFW_KEY_SLASH:
      if ((mods & GLFW_MOD_SHIFT) != 0) v.help_open = !v.help_open;  // ?
      break;
    case GLFW_KEY_O:
      if (ctrl)
        v.open_dialog.open = true, v.open_dialog.folder = std::filesystem::current_path(),
        v.open_dialog.entries = list_openable(v.open_dialog.folder);
      break;
    case GLFW_KEY_R:
      if (ctrl) reload(v);
      break;
    case GLFW_KEY_ESCAPE:
      if (v.help_open)
        v.help_open = false;
      else
        v.quit = true;
      break;
    default: break;
  }
}

namespace {
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
    int width = 0, height = 0;
    glfwGetFramebufferSize(w, &width, &height);
    press_key(v, key, mods, width, height);
    if (v.quit) glfwSetWindowShouldClose(w, GLFW_TRUE);
  });
  // A file dropped on the window is opened (the first, when several are).
  glfwSetDropCallback(window, [](GLFWwindow* w, int count, const char** paths) {
    if (count > 0) open_path(state_of(w), paths[0]);
  });
}

// Frames the box in the middle of what the panels leave: fitted, then moved back until each of its
// corners is seen there (a box off the view's axis looks wider than on it).
void fit_between_panels(ViewerState& v, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const double left = v.show_panels ? kPanelWidth : 0.0, right = v.inspector_open ? kInspectorWidth : 0.0;
  const double free_width = std::max(80.0, v.camera.width - left - right);
  v.camera.fit(lo, hi, free_width);
  const auto seen = [&] {
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d p((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
      const Eigen::Vector2d px = v.camera.project(p);
      if (!(px.x() > left && px.x() < v.camera.width - right && px.y() > v.menu_height && px.y() < v.camera.height))
        return false;
    }
    return true;
  };
  for (int tries = 0; tries < 30; ++tries) {
    v.camera.target = 0.5 * (lo + hi);
    v.camera.pan(0.5 * (left - right), 0.0);
    if (seen()) break;
    v.camera.distance *= 1.08;
  }
  v.panels_were_shown = v.show_panels;
  v.inspector_was_open = v.inspector_open;
}

// Copies what the window needs from the newest frame and builds its geometry; the slot is held
// only for this.
void take_frame(ViewerState& v, GlScene& scene) {
  FramePublisher& frames = v.sim.frames();
  frames.skin_on_gpu(scene.wants_gpu_skinning(v.draw));  // the frame as rings for the shader, or skinned here
  const FramePublisher::Slot& f = frames.acquire();
  v.model = v.sim.model();  // matches the slot: a rebuild waits for the release below
  const ModelInfo& m = *v.model;
  v.scene_name = m.scene_name;  // another scene may have been opened
  v.scene_dt = m.scene_dt;
  v.scene_frames = m.scene_frames;
  const bool fresh = f.frame != v.frame || v.bead_centres.empty();
  v.frame = f.frame;
  v.time = f.time;
  v.profile = f.details.profile;
  v.instruments = f.details.instruments;
  v.contact_count = f.details.contacts.size();
  v.node_positions.resize(f.x.size());
  for (std::size_t k = 0; k < f.x.size(); ++k) v.node_positions[k] = {f.x[k], f.y[k], f.z[k]};
  v.bead_centres.resize(m.bead_nodes.size());
  for (std::size_t i = 0; i < m.bead_nodes.size(); ++i) {
    const std::size_t k = m.bead_nodes[i];
    v.bead_centres[i] = {f.x[k], f.y[k], f.z[k]};
  }
  if (!v.camera_fitted && !f.x.empty() && m.generation >= v.fit_from_generation) {
    const auto [lo, hi] = drawn_bounds(f, m);
    fit_between_panels(v, lo, hi);
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
      if (!m.organs.empty()) {
        const Range last = m.segment_nodes[m.organs.front().pieces.back()];
        const std::size_t k = last.offset + last.count - 1;
        s.end = {f.x[k], f.y[k], f.z[k]};
      }
      if (r.grasping && r.grasped_segment < m.segment_nodes.size()) {
        s.node = m.segment_nodes[r.grasped_segment].offset + r.grasped_node;
        s.node_position = {f.x[s.node], f.y[s.node], f.z[s.node]};
      }
      v.samples.push_back(s);
    }
  }
  scene.build(f, m, v.draw, v.camera);
  if (scene.organ_on_gpu() != v.organ_on_gpu) {  // recorded: which skinning drew the frames from here
    InputEvent e;
    e.kind = scene.organ_on_gpu() ? "skinning gpu" : "skinning cpu";
    e.frame = f.frame;
    e.camera = v.camera;
    v.events.push_back(e);
  }
  v.organ_on_gpu = scene.organ_on_gpu();
  frames.release();
}

nlohmann::json vec(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

void write_record(const ViewerState& v, const std::string& path) {
  nlohmann::json j;
  j["scene"] = v.scene_name;
  j["frames"] = v.frame;
  j["unstable"] = v.sim.went_unstable();
  j["organ_on_gpu"] = v.organ_on_gpu;  // the last frame's organ was skinned by the GPU (decision 0110)
  for (const Sample& s : v.samples)
    j["samples"].push_back({{"frame", s.frame},
                            {"time", s.time},
                            {"grasping", s.grasping},
                            {"node", s.node},
                            {"node_position", vec(s.node_position)},
                            {"tip", vec(s.tip)},
                            {"force", vec(s.force)},
                            {"filtered_force", vec(s.filtered_force)},
                            {"anchors_cut", s.anchors_cut},
                            {"end", vec(s.end)}});
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
                             {"height", c.height}}},
                           {"drawn", {vec(e.drawn[0]), vec(e.drawn[1])}}});
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

GLFWwindow* try_window(const ViewerOptions& o, const std::string& title, int samples) {
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SAMPLES, samples);
  GLFWwindow* w = glfwCreateWindow(o.width, o.height, title.c_str(), nullptr, nullptr);
  if (w == nullptr)
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("no window with OpenGL 3.3: {} (run on a desktop, or under xvfb-run with Mesa)", g_glfw_error));
  glfwMakeContextCurrent(w);
  glfwSwapInterval(1);
  return w;
}

// Multisampling costs a software renderer (Mesa's llvmpipe) 2.5 times the frame (bench_draw): left
// out there unless asked for.
GLFWwindow* open_window(const ViewerOptions& o, const std::string& title, std::string& renderer) {
  GLFWwindow* w = try_window(o, title, o.samples < 0 ? 4 : o.samples);
  renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const bool software = renderer.find("llvmpipe") != std::string::npos ||
                        renderer.find("softpipe") != std::string::npos || renderer.find("swrast") != std::string::npos;
  if (o.samples < 0 && software) {
    glfwDestroyWindow(w);
    w = try_window(o, title, 0);
  }
  return w;
}

int loop(ViewerState& v, GLFWwindow* window, std::optional<ScriptPlayer>& script, const ViewerOptions& o) {
  GlScene scene;
  v.scene = &scene;
  const auto frame_budget = std::chrono::microseconds(16'000);  // ~60 Hz: the other core is the physics'
  while (glfwWindowShouldClose(window) == GLFW_FALSE && !v.quit) {
    const auto started = std::chrono::steady_clock::now();
    glfwPollEvents();
    // A frame of physics per window frame (a script's, whatever the load), or while a video is
    // written, the frames of simulated time between two of its frames.
    if (script || v.video.recording()) v.sim.step_in_lockstep(v.video.recording() ? v.video_frames_per_shot : 1);
    for (std::string& line : v.sim.take_log()) v.note(std::move(line));
    if (script && !script->tick(v)) v.quit = true;
    if (!script && !o.screenshot.empty() && v.frame >= static_cast<std::uint64_t>(v.scene_frames)) v.quit = true;
    int fbw = 0, fbh = 0, ww = 0, wh = 0;
    glfwGetFramebufferSize(window, &fbw, &fbh);
    glfwGetWindowSize(window, &ww, &wh);
    v.camera.width = std::max(ww, 1);
    v.camera.height = std::max(wh, 1);
    if (v.auto_reload && scene_file_changed(v)) {
      v.note("the scene file changed: reloading");
      reload(v);
    }
    take_frame(v, scene);
    keep_between_panels(v);
    follow(v);
    keep_above_planes(v);
    scene.draw(v.camera, v.draw, fbw, fbh);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    draw_menu_bar(v, fbw, fbh);
    draw_panels(v);
    draw_inspector(v);
    draw_open_dialog(v);
    draw_help(v);
    draw_overlays(v);
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    video_frame(v, fbw, fbh);
    if (!v.video_pending.empty()) {  // a script's `record FILE` (from the next frame) or `record stop` (after this one)
      if (v.video_pending == "stop" && !v.video.recording())
        v.note("record stop: no video is being recorded");
      else
        v.note(toggle_video(v, fbw, fbh, v.video_pending == "stop" ? std::string() : v.video_pending));
      v.video_pending.clear();
    }
    if (!v.screenshot_pending.empty()) {
      save_screenshot(v.screenshot_pending, fbw, fbh);
      v.screenshots.push_back(v.screenshot_pending);
      v.screenshot_pending.clear();
    }
    if (v.quit && !o.screenshot.empty()) save_screenshot(o.screenshot, fbw, fbh);
    glfwSwapBuffers(window);
    if (!script && !v.video.recording()) std::this_thread::sleep_until(started + frame_budget);
  }
  if (v.video.recording()) v.note(toggle_video(v, 0, 0));
  v.scene = nullptr;  // the scene goes with this function
  return script && v.sim.went_unstable() ? kExitUnstable : 0;
}

}  // namespace

int run_viewer(const ViewerOptions& o) {
  // The scene first: a scene that does not load fails as `haustra run` fails, display or not.
  const SceneDesc scene = load_scene(o.scene, o.sets);
  std::optional<ScriptPlayer> script;
  if (!o.script.empty()) script.emplace(read_script(o.script));
  Simulation sim(scene, o.threads, o.checkpoint, o.paused, /*lockstep=*/script.has_value(),
                 o.source.empty() ? o.scene : o.source, o.sets);
  GlfwSession glfw;
  std::string renderer;
  GLFWwindow* window = open_window(o, fmt::format("haustra view - {}", scene.name), renderer);
  ViewerState v(sim);
  v.note(fmt::format("drawing with {}", renderer));
  v.draw.triangle_budget = o.triangle_budget;
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
