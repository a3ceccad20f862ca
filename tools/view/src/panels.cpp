// ImGui panels over the 3D view.
#include "panels.hpp"

#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <cmath>

#include "haustra/error.hpp"
#include "knobs.hpp"

namespace haustra::view {
namespace {

void status(ViewerState& v) {
  const SimulationStats s = v.sim.stats();
  ImGui::TextWrapped("%s", v.scene_name.c_str());  // a long name wraps: the counters keep their own line
  ImGui::Text("frame %llu  t = %.3f s", static_cast<unsigned long long>(v.frame), v.time);
  const double draws = static_cast<double>(ImGui::GetIO().Framerate);
  // While paused or stepped by a script there is no rate to show: say so, not the last figures.
  if (s.paused) {
    ImGui::Text("paused   last step %.3f ms   %.0f draws/s", 1e3 * v.profile.frame_seconds, draws);
  } else if (v.sim.held()) {
    ImGui::Text("one frame per draw   step %.3f ms   %.0f draws/s", 1e3 * v.profile.frame_seconds, draws);
  } else {
    ImGui::Text("step %.3f ms   real time x%.2f", 1e3 * v.profile.frame_seconds, s.real_time_factor);
    ImGui::Text("%.0f steps/s   %.0f draws/s", s.steps_per_second, draws);
  }
  ImGui::Text("iterations %d  substeps %d  retries %d  fallbacks %d  contacts %zu", v.profile.iterations,
              v.profile.substeps, v.profile.retries, v.profile.fallbacks, v.contact_count);
  if (v.profile.nodes_asleep > 0)  // the scene's [sleep]: rods and ranges held, not solved (0119, 0127)
    ImGui::Text("nodes asleep %d", v.profile.nodes_asleep);
  if (s.unstable) {
    ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1, 0.3f, 0.2f, 1));
    ImGui::TextWrapped("stopped: %s", s.stop_reason.c_str());
    ImGui::PopStyleColor();
  }
  if (ImGui::Button(s.paused ? "Run" : "Pause")) v.sim.post(SetPaused{!s.paused});
  ImGui::SameLine();
  if (ImGui::Button("Step")) v.sim.post(StepOnce{});
  ImGui::SameLine();
  if (ImGui::Button("Reset")) v.sim.post(Reset{});
  ImGui::SameLine();
  if (ImGui::Button("Save")) v.sim.post(SaveCheckpoint{});
  ImGui::SameLine();
  if (ImGui::Button("Restore")) v.sim.post(RestoreCheckpoint{});
}

void stages(ViewerState& v) {
  const double total = std::max(v.profile.frame_seconds, 1e-12);
  for (std::size_t i = 0; i < kStageCount; ++i) {
    if (v.profile.calls[i] == 0) continue;
    const double s = v.profile.seconds[i];
    const std::string_view name = stage_name(static_cast<Stage>(i));
    ImGui::Text("%-14.*s", static_cast<int>(name.size()), name.data());
    ImGui::SameLine(120);
    ImGui::ProgressBar(static_cast<float>(s / total), ImVec2(-1, 0), fmt::format("{:.1f} us", 1e6 * s).c_str());
  }
}

void force_plot(const ForcePlot& p) {
  float top = 0.1f;
  for (float f : p.raw) top = std::max(top, f);
  const ImVec2 size(ImGui::GetContentRegionAvail().x, 90);
  const ImVec2 origin = ImGui::GetCursorScreenPos();
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(origin, ImVec2(origin.x + size.x, origin.y + size.y), IM_COL32(30, 30, 36, 255));
  const auto series = [&](const std::deque<float>& values, ImU32 colour) {
    for (std::size_t i = 1; i < values.size(); ++i) {
      const std::size_t shift = ForcePlot::kSamples - values.size();  // the newest sample at the right edge
      const auto px = [&](std::size_t k) {
        return origin.x + size.x * static_cast<float>(k + shift) / (ForcePlot::kSamples - 1);
      };
      const auto py = [&](float f) { return origin.y + size.y * (1.0f - f / top); };
      dl->AddLine(ImVec2(px(i - 1), py(values[i - 1])), ImVec2(px(i), py(values[i])), colour, 1.5f);
    }
  };
  series(p.raw, IM_COL32(240, 140, 40, 255));
  series(p.filtered, IM_COL32(90, 200, 255, 255));
  ImGui::Dummy(size);
  const float raw = p.raw.empty() ? 0.0f : p.raw.back(), filtered = p.filtered.empty() ? 0.0f : p.filtered.back();
  ImGui::TextColored(ImVec4(0.94f, 0.55f, 0.16f, 1), "raw %.3f N", static_cast<double>(raw));
  ImGui::SameLine();
  ImGui::TextColored(ImVec4(0.35f, 0.78f, 1, 1), "filtered %.3f N", static_cast<double>(filtered));
  ImGui::SameLine();
  ImGui::Text("(top %.2f N)", static_cast<double>(top));
}

void display(ViewerState& v) {
  ImGui::Checkbox("beads", &v.draw.beads);
  ImGui::SameLine();
  if (ImGui::Checkbox("cage", &v.draw.cage)) v.sim.frames().want_cages(v.draw.cage);
  ImGui::SameLine();
  ImGui::Checkbox("centreline", &v.draw.centreline);
  ImGui::SameLine();
  ImGui::Checkbox("contacts", &v.draw.contacts);
  if (v.model && !v.model->anchor_nodes.empty()) ImGui::Checkbox("tissue (T; Shift-drag cuts it)", &v.draw.anchors);
  int colour = static_cast<int>(v.draw.colour);
  if (ImGui::Combo("colour", &colour, "tissue\0strain (bending, 1/m)\0penetration (depth / r)\0"))
    v.draw.colour = static_cast<Colouring>(colour);
  if (v.draw.colour == Colouring::strain) {
    float range = static_cast<float>(v.draw.strain_range);
    if (ImGui::SliderFloat("strain range", &range, 0.5f, 50.0f, "%.1f 1/m")) v.draw.strain_range = range;
  }
}

void knobs(ViewerState& v) {
  if (!v.model) return;
  const WorldDesc& d = v.model->desc;
  ImGui::TextDisabled("each change rebuilds the model and keeps the state");
  int mode = static_cast<int>(d.solver.mode);
  if (ImGui::Combo("solver", &mode, "lagged\0newton\0fast\0"))
    turn_knob(v, "mode", solver_mode_name(static_cast<SolverMode>(mode)));
  static int iterations = 0;
  if (!ImGui::IsAnyItemActive()) iterations = d.solver.iterations;
  ImGui::SliderInt("iterations", &iterations, 1, 8);
  if (ImGui::IsItemDeactivatedAfterEdit()) turn_knob(v, "iterations", std::to_string(iterations));
  bool filter = d.filter.enabled;
  if (ImGui::Checkbox("inertia filter", &filter)) turn_knob(v, "filter", filter ? "on" : "off");
  int law = !d.segments.empty() && d.segments[0].material.response == TissueResponse::exp2 ? 1 : 0;
  if (ImGui::Combo("tissue law", &law, "hooke\0exp2 (Newton)\0")) turn_knob(v, "law", law == 1 ? "exp2" : "hooke");
  static float per_node = 0.0f;
  if (!ImGui::IsAnyItemActive()) per_node = static_cast<float>(beads_per_node(d));
  ImGui::SliderFloat("beads per node", &per_node, 0.05f, 1.0f, "%.2f");
  if (ImGui::IsItemDeactivatedAfterEdit()) turn_knob(v, "beads_per_node", fmt::format("{}", per_node));
  const SkinningMethod now = d.segments.empty() ? SkinningMethod::along_rod : d.segments[0].mesh.skinning;
  int skin = static_cast<int>(std::find(kSkins.begin(), kSkins.end(), now) - kSkins.begin());
  if (ImGui::Combo("skin", &skin, "along the rod\0cage (MVC)\0cage, every ring\0linear blend\0"))
    turn_knob(v, "skin", std::string(kSkinNames[static_cast<std::size_t>(skin)]));
  static float gravity[3] = {0, 0, 0};
  if (!ImGui::IsAnyItemActive())
    for (int i = 0; i < 3; ++i) gravity[i] = static_cast<float>(d.gravity[i]);
  ImGui::InputFloat3("gravity", gravity, "%.2f");
  if (ImGui::IsItemDeactivatedAfterEdit())
    turn_knob(v, "gravity", fmt::format("{} {} {}", gravity[0], gravity[1], gravity[2]));
  bool khz = std::abs(d.dt - 1e-3) < 1e-12;
  if (ImGui::Checkbox(fmt::format("1 kHz (scene: {:.4g} s)", v.scene_dt).c_str(), &khz))
    turn_knob(v, "rate", khz ? "1khz" : "scene");
}

void log_panel(ViewerState& v) {
  ImGui::BeginChild("log", ImVec2(0, 120), true, ImGuiWindowFlags_HorizontalScrollbar);
  for (const std::string& line : v.log) ImGui::TextUnformatted(line.c_str());
  if (ImGui::GetScrollY() >= ImGui::GetScrollMaxY()) ImGui::SetScrollHereY(1.0f);
  ImGui::EndChild();
}

}  // namespace

void turn_knob(ViewerState& v, const std::string& name, const std::string& value) {
  try {
    (void)set_knob(v.model->desc, name, value, v.scene_dt);  // refused here, at once, when it is not a value
    v.note(fmt::format("knob {} = {} (rebuilding)", name, value));
    v.sim.post(Reconfigure{name, value});
  } catch (const Error& e) {
    v.note(e.what());
  }
}

void keep_inside(const ViewerState& v) {
  const float top = v.menu_height + 8.0f;
  const ImVec2 pos = ImGui::GetWindowPos(), size = ImGui::GetWindowSize();
  const float w = static_cast<float>(v.camera.width), h = static_cast<float>(v.camera.height);
  if (size.y > h - top) ImGui::SetWindowSize(ImVec2(size.x, std::max(80.0f, h - top - 8.0f)));
  if (size.x > w - 16.0f) ImGui::SetWindowSize(ImVec2(std::max(120.0f, w - 16.0f), ImGui::GetWindowSize().y));
  const ImVec2 inside(std::clamp(pos.x, 0.0f, std::max(0.0f, w - 60.0f)),
                      std::clamp(pos.y, v.menu_height, std::max(v.menu_height, h - 40.0f)));
  if (inside.x != pos.x || inside.y != pos.y) ImGui::SetWindowPos(inside);
}

void draw_panels(ViewerState& v) {
  if (!v.show_panels) return;
  const float top = v.menu_height + 8.0f, room = static_cast<float>(v.camera.height) - top - 8.0f;
  ImGui::SetNextWindowPos(ImVec2(8, top), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(kPanelWidth, room), ImGuiCond_FirstUseEver);
  ImGui::Begin("haustra");
  keep_inside(v);
  status(v);
  if (ImGui::CollapsingHeader("mouse grasper force (N)", ImGuiTreeNodeFlags_DefaultOpen)) force_plot(v.plot);
  for (std::size_t i = 0; v.model && i < v.plots.size() && i < v.model->desc.instruments.size(); ++i)
    if (ImGui::CollapsingHeader(fmt::format("{} force (N)##{}", v.model->desc.instruments[i].name, i).c_str()))
      force_plot(v.plots[i]);
  if (ImGui::CollapsingHeader("stages", ImGuiTreeNodeFlags_DefaultOpen)) stages(v);
  if (ImGui::CollapsingHeader("display", ImGuiTreeNodeFlags_DefaultOpen)) display(v);
  if (ImGui::CollapsingHeader("knobs")) knobs(v);
  if (ImGui::CollapsingHeader("log", ImGuiTreeNodeFlags_DefaultOpen)) log_panel(v);
  ImGui::End();
}

}  // namespace haustra::view
