// The main menu bar, File > Open, the help overlay and the notices over the view (Dear ImGui).
#include "menus.hpp"

#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <array>

#include "actions.hpp"
#include "haustra/render/shapes.hpp"

namespace haustra::view {
namespace {

constexpr double kNoticeSeconds = 8.0;  // a notice stays this long on screen

// Every key and mouse action, as the help overlay lists them.
constexpr std::array<std::pair<const char*, const char*>, 25> kHelp = {{
    {"left-drag on the organ", "grasp the bead under the pointer and drag it (in the view plane)"},
    {"  with Ctrl", "drag along the view axis"},
    {"  with Shift", "cut the connective tissue under the pointer, along the drag"},
    {"left-drag elsewhere", "orbit"},
    {"right-drag", "pan"},
    {"wheel", "zoom"},
    {"Space", "pause / run"},
    {"Right arrow", "one frame"},
    {"Ctrl+O", "open a scene or a surface (also: drop a file on the window)"},
    {"Ctrl+R", "reload the scene from its file (automatic when it changes, see File)"},
    {"P", "screenshot (PNG)"},
    {"V", "start / stop a video at the physics' own time (needs ffmpeg)"},
    {"1 / 2 / 3", "camera from the front / top / side"},
    {"0", "the default camera"},
    {"F", "fit the camera to the organ"},
    {"G", "follow the grasped (or selected) part"},
    {"B", "beads"},
    {"T", "connective tissue (anchors; torn and cut ones as dots)"},
    {"K", "skin the organ on the GPU (default where GL runs the shader) or on the CPU"},
    {"Tab", "panels"},
    {"I", "the inspector: organs, instruments, tissue, obstacles; select to highlight, edit live"},
    {"F1, H, ?", "this help"},
    {"Esc", "close this help, or quit"},
    {"Knobs (panel)", "solver, iterations, filter, law, beads, rings, gravity, contact, rate"},
    {"--script FILE", "the same by script (tools/view/src/script.hpp)"},
}};

void file_menu(ViewerState& v, int width, int height) {
  if (!ImGui::BeginMenu("File")) return;
  if (ImGui::MenuItem("Open...", "Ctrl+O")) {
    v.open_dialog.open = true;
    v.open_dialog.folder = v.model && !v.model->scene_path.empty()
                               ? std::filesystem::path(v.model->scene_path).parent_path()
                               : std::filesystem::current_path();
    v.open_dialog.entries = list_openable(v.open_dialog.folder);
  }
  if (ImGui::MenuItem("Reload", "Ctrl+R", false, v.model && !v.model->scene_path.empty())) reload(v);
  ImGui::MenuItem("Reload when the file changes", nullptr, &v.auto_reload);
  ImGui::Separator();
  if (ImGui::MenuItem("Screenshot", "P")) v.note("screenshot " + take_screenshot(v));
  if (ImGui::MenuItem(v.video.recording() ? "Stop the video" : "Record a video", "V"))
    v.note(toggle_video(v, width, height));
  ImGui::Separator();
  if (ImGui::MenuItem("Quit", "Esc")) v.quit = true;
  ImGui::EndMenu();
}

void view_menu(ViewerState& v) {
  if (!ImGui::BeginMenu("View")) return;
  if (ImGui::MenuItem("Front", "1")) set_view(v, View::front);
  if (ImGui::MenuItem("Top", "2")) set_view(v, View::top);
  if (ImGui::MenuItem("Side", "3")) set_view(v, View::side);
  if (ImGui::MenuItem("Default", "0")) set_view(v, View::standard);
  if (ImGui::MenuItem("Fit", "F")) v.camera_fitted = false;
  ImGui::MenuItem("Follow", "G", &v.follow);
  ImGui::Separator();
  ImGui::MenuItem("Beads", "B", &v.draw.beads);
  if (ImGui::MenuItem("Cage", nullptr, &v.draw.cage)) v.sim.frames().want_cages(v.draw.cage);
  ImGui::MenuItem("Centreline", nullptr, &v.draw.centreline);
  ImGui::MenuItem("Contacts", nullptr, &v.draw.contacts);
  ImGui::MenuItem("Connective tissue", "T", &v.draw.anchors);
  ImGui::MenuItem("Skinning on the GPU", "K", &v.draw.gpu_skinning);
  ImGui::MenuItem("Panels", "Tab", &v.show_panels);
  ImGui::MenuItem("Inspector", "I", &v.inspector_open);
  ImGui::EndMenu();
}

void simulation_menu(ViewerState& v) {
  if (!ImGui::BeginMenu("Simulation")) return;
  const SimulationStats s = v.sim.stats();
  if (ImGui::MenuItem(s.paused ? "Run" : "Pause", "Space")) v.sim.post(SetPaused{!s.paused});
  if (ImGui::MenuItem("Step", "Right")) v.sim.post(StepOnce{});
  if (ImGui::MenuItem("Reset")) v.sim.post(Reset{});
  if (ImGui::MenuItem("Save checkpoint")) v.sim.post(SaveCheckpoint{});
  if (ImGui::MenuItem("Restore checkpoint")) v.sim.post(RestoreCheckpoint{});
  ImGui::EndMenu();
}

ImVec4 colour_of(Notice::Kind kind) {
  switch (kind) {
    case Notice::Kind::error: return ImVec4(1.0f, 0.45f, 0.35f, 1.0f);
    case Notice::Kind::warning: return ImVec4(1.0f, 0.78f, 0.3f, 1.0f);
    case Notice::Kind::info: break;
  }
  return ImVec4(0.8f, 0.9f, 1.0f, 1.0f);
}

// The colour scale of the strain or penetration colouring, bottom left of the view.
void legend(ViewerState& v) {
  if (v.draw.colour == Colouring::tissue) return;
  const bool strain = v.draw.colour == Colouring::strain;
  const double top = strain ? v.draw.strain_range : 0.05;
  const ImVec2 at(v.show_panels ? kPanelWidth + 24.0f : 16.0f, static_cast<float>(v.camera.height) - 64.0f);
  ImDrawList* dl = ImGui::GetForegroundDrawList();
  constexpr int kSteps = 64;
  constexpr float kWidth = 240.0f, kHeight = 14.0f;
  for (int i = 0; i < kSteps; ++i) {
    const render::Rgb c = render::colormap(static_cast<double>(i) / (kSteps - 1));
    const auto srgb = [](float x) {
      return static_cast<int>(255.0f * std::pow(std::clamp(x, 0.0f, 1.0f), 1.0f / 2.2f));
    };
    dl->AddRectFilled(ImVec2(at.x + kWidth * i / kSteps, at.y),
                      ImVec2(at.x + kWidth * (i + 1) / kSteps, at.y + kHeight),
                      IM_COL32(srgb(c.r), srgb(c.g), srgb(c.b), 255));
  }
  const ImU32 text = IM_COL32(20, 20, 30, 255);
  dl->AddText(ImVec2(at.x, at.y + kHeight + 2), text, "0");
  const std::string end = strain ? fmt::format("{:.3g} 1/m", top) : fmt::format("{:.0f} % of the radius", 100 * top);
  dl->AddText(ImVec2(at.x + kWidth - ImGui::CalcTextSize(end.c_str()).x, at.y + kHeight + 2), text, end.c_str());
  const char* what = strain ? "bending strain |kappa - kappa_rest|" : "deepest contact of each bead";
  dl->AddText(ImVec2(at.x, at.y - 16), text, what);
}

}  // namespace

std::vector<std::string> list_openable(const std::filesystem::path& folder) {
  std::vector<std::string> folders, files;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = e.path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    if (e.is_directory(ec)) {
      folders.push_back(name + "/");
      continue;
    }
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".toml" || ext == ".obj" || ext == ".stl" || ext == ".off" || ext == ".gltf" || ext == ".glb")
      files.push_back(name);
  }
  std::sort(folders.begin(), folders.end());
  std::sort(files.begin(), files.end());
  folders.insert(folders.end(), files.begin(), files.end());
  return folders;
}

void draw_menu_bar(ViewerState& v, int width, int height) {
  if (!ImGui::BeginMainMenuBar()) return;
  file_menu(v, width, height);
  view_menu(v);
  simulation_menu(v);
  if (ImGui::BeginMenu("Help")) {
    ImGui::MenuItem("Keys and mouse", "F1", &v.help_open);
    ImGui::EndMenu();
  }
  if (v.video.recording()) {
    ImGui::SameLine(ImGui::GetWindowWidth() - 260);
    ImGui::TextColored(ImVec4(1, 0.3f, 0.3f, 1), "REC %zu frames", v.video.frames());
  }
  v.menu_height = ImGui::GetWindowSize().y;
  ImGui::EndMainMenuBar();
}

void draw_open_dialog(ViewerState& v) {
  OpenDialog& d = v.open_dialog;
  if (!d.open) return;
  ImGui::SetNextWindowSize(ImVec2(520, 420), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowPos(ImVec2(0.5f * static_cast<float>(v.camera.width), 0.5f * static_cast<float>(v.camera.height)),
                          ImGuiCond_FirstUseEver, ImVec2(0.5f, 0.5f));
  if (!ImGui::Begin("Open a scene or a surface", &d.open)) {
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("%s", d.folder.string().c_str());
  if (ImGui::Button("..")) {
    d.folder = d.folder.parent_path();
    d.entries = list_openable(d.folder);
  }
  ImGui::BeginChild("entries", ImVec2(0, -60), true);
  for (const std::string& e : d.entries) {
    if (!ImGui::Selectable(e.c_str(), d.path == (d.folder / e).string(), ImGuiSelectableFlags_AllowDoubleClick))
      continue;
    if (e.ends_with("/")) {
      d.folder /= e.substr(0, e.size() - 1);
      d.entries = list_openable(d.folder);
    } else {
      d.path = (d.folder / e).string();
      if (ImGui::IsMouseDoubleClicked(0)) {
        open_path(v, d.path);
        d.open = false;
      }
    }
  }
  ImGui::EndChild();
  static std::array<char, 1024> typed{};
  if (d.path.size() < typed.size()) std::copy_n(d.path.c_str(), d.path.size() + 1, typed.begin());
  if (ImGui::InputText("file", typed.data(), typed.size())) d.path = typed.data();
  if (ImGui::Button("Open") && !d.path.empty()) {
    open_path(v, d.path);
    d.open = false;
  }
  ImGui::SameLine();
  ImGui::TextDisabled("scenes (.toml) and surfaces (.obj .stl .off .gltf .glb, imported first)");
  ImGui::End();
}

void draw_help(ViewerState& v) {
  if (!v.help_open) return;
  ImGui::SetNextWindowPos(ImVec2(0.5f * static_cast<float>(v.camera.width), 0.5f * static_cast<float>(v.camera.height)),
                          ImGuiCond_Always, ImVec2(0.5f, 0.5f));
  ImGui::Begin("Help: keys and mouse", &v.help_open,
               ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoSavedSettings);
  if (ImGui::BeginTable("keys", 2, ImGuiTableFlags_RowBg)) {
    for (const auto& [key, what] : kHelp) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(key);
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(what);
    }
    ImGui::EndTable();
  }
  ImGui::End();
}

void draw_overlays(ViewerState& v) {
  const auto now = std::chrono::steady_clock::now();
  for (Notice& n : v.sim.take_notices()) v.notices.push_back({std::move(n), now});
  while (!v.notices.empty() && now - v.notices.front().since > std::chrono::duration<double>(kNoticeSeconds))
    v.notices.pop_front();
  const SimulationStats s = v.sim.stats();
  if (!v.notices.empty() || !s.busy.empty()) {
    // Over the view, between the panels and the inspector: neither hides the other.
    const float left = v.show_panels ? kPanelWidth + 16.0f : 12.0f;
    const float right = static_cast<float>(v.camera.width) - (v.inspector_open ? kInspectorWidth + 20.0f : 12.0f);
    const float w = std::clamp(right - left, 160.0f, 520.0f);
    ImGui::SetNextWindowPos(ImVec2(std::max(left, right - w), v.menu_height + 8.0f));
    ImGui::SetNextWindowSize(ImVec2(w, 0));
    ImGui::SetNextWindowBgAlpha(0.75f);
    ImGui::Begin("##notices", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoInputs | ImGuiWindowFlags_NoSavedSettings |
                     ImGuiWindowFlags_NoFocusOnAppearing | ImGuiWindowFlags_AlwaysAutoResize);
    if (!s.busy.empty()) {
      static constexpr const char* kSpin = "|/-\\";
      const auto tick = static_cast<std::size_t>(ImGui::GetTime() * 8.0) % 4;
      ImGui::Text("%c %s", kSpin[tick], s.busy.c_str());
    }
    for (const ShownNotice& n : v.notices) {
      ImGui::PushStyleColor(ImGuiCol_Text, colour_of(n.notice.kind));
      ImGui::TextWrapped("%s", n.notice.text.c_str());
      ImGui::PopStyleColor();
    }
    ImGui::End();
  }
  legend(v);
}

}  // namespace haustra::view
