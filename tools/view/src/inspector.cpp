// The inspector: the scene's tree, the selection's values, and live edits posted to the physics thread.
#include "inspector.hpp"

#include <fmt/format.h>
#include <imgui.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <span>

#include "panels.hpp"

namespace haustra::view {
namespace {

using Kind = Highlight::Kind;

constexpr std::array<std::pair<std::string_view, Kind>, 8> kKinds = {{{"none", Kind::none},
                                                                      {"organ", Kind::organ},
                                                                      {"anchors", Kind::anchors},
                                                                      {"instrument", Kind::instrument},
                                                                      {"plane", Kind::plane},
                                                                      {"sphere", Kind::sphere},
                                                                      {"capsule", Kind::capsule},
                                                                      {"mesh", Kind::mesh}}};

std::optional<Kind> kind_of(std::string_view word) {
  for (const auto& [name, kind] : kKinds)
    if (name == word) return kind;
  return std::nullopt;
}

std::string_view word_of(Kind kind) {
  for (const auto& [name, k] : kKinds)
    if (k == kind) return name;
  return "none";
}

// How many of a kind the open scene has.
std::size_t count_of(const ModelInfo& m, Kind kind) {
  const EnvironmentDesc& e = m.desc.environment;
  switch (kind) {
    case Kind::organ:
    case Kind::anchors: return m.organs.size();
    case Kind::instrument: return m.desc.instruments.size();
    case Kind::plane: return e.planes.size();
    case Kind::sphere: return e.spheres.size();
    case Kind::capsule: return e.capsules.size();
    case Kind::mesh: return e.meshes.size();
    case Kind::none: break;
  }
  return 0;
}

std::string instrument_name(const ModelInfo& m, std::size_t i) {
  return i == m.mouse ? std::string("mouse grasper") : m.desc.instruments[i].name;
}

// An editable field. Here only its sign is checked, for an answer at once; the engine checks the
// rest as the scene reader does and refuses on screen, the world left as it was.
struct Field {
  std::string_view name, unit;
  bool zero_allowed;
};
constexpr Field kOrganFields[] = {{"youngs_modulus", "Pa", false}, {"relaxation_time", "s", true}};
constexpr Field kInstrumentFields[] = {
    {"stiffness", "N/m", true}, {"damping", "N s/m", true}, {"force_limit", "N", false}};

const Field* field_of(std::span<const Field> fields, std::string_view name) {
  for (const Field& f : fields)
    if (f.name == name) return &f;
  return nullptr;
}

std::string field_names(std::span<const Field> fields) {
  std::string names;
  for (const Field& f : fields) names += (names.empty() ? "" : ", ") + std::string(f.name);
  return names;
}

std::optional<std::string> refused(const Field& f, double x) {
  if (std::isfinite(x) && (x > 0.0 || (f.zero_allowed && x == 0.0))) return std::nullopt;
  return fmt::format("{}: {} is not {} ({})", f.name, x, f.zero_allowed ? "zero or more" : "more than zero", f.unit);
}

}  // namespace

std::string select_part(ViewerState& v, std::string_view kind, std::size_t index) {
  const std::optional<Kind> k = kind_of(kind);
  if (!k)
    return fmt::format("select: '{}' is not organ, anchors, instrument, plane, sphere, capsule, mesh or none", kind);
  if (*k != Kind::none && (!v.model || index >= count_of(*v.model, *k)))
    return fmt::format("select: no {} {} (the scene has {})", kind, index, v.model ? count_of(*v.model, *k) : 0);
  v.draw.highlight = {*k, *k == Kind::none ? 0 : index};
  v.inspector_open = true;
  return *k == Kind::none ? std::string("selection cleared") : fmt::format("selected {} {}", kind, index);
}

std::string edit_value(ViewerState& v, std::string_view kind, std::size_t index, std::string_view field, double value) {
  if (!v.model) return "edit: no scene open";
  const ModelInfo& m = *v.model;
  if (kind == "contact") {
    if (field != "coefficient") return fmt::format("edit contact: no field '{}' (coefficient)", field);
    turn_knob(v, "contact", fmt::format("{}", value));
    return fmt::format("contact coefficient = {}", value);
  }
  if (kind == "organ") {
    if (index >= m.organs.size()) return fmt::format("edit: no organ {} (the scene has {})", index, m.organs.size());
    const Field* f = field_of(kOrganFields, field);
    if (!f) return fmt::format("edit organ: no field '{}' ({})", field, field_names(kOrganFields));
    if (auto bad = refused(*f, value)) return "edit organ " + *bad;
    const ModelInfo::Organ& o = m.organs[index];
    EditMaterial e{index, o.desc.material.youngs_modulus, o.desc.relaxation_time};
    (field == "youngs_modulus" ? e.youngs_modulus : e.relaxation_time) = value;
    v.sim.post(e);
    return fmt::format("{}: {} = {} {}", o.name, field, value, f->unit);
  }
  if (kind == "instrument") {
    if (index >= m.desc.instruments.size())
      return fmt::format("edit: no instrument {} (the scene has {})", index, m.desc.instruments.size());
    const Field* f = field_of(kInstrumentFields, field);
    if (!f) return fmt::format("edit instrument: no field '{}' ({})", field, field_names(kInstrumentFields));
    if (auto bad = refused(*f, value)) return "edit instrument " + *bad;
    const InstrumentDesc& d = m.desc.instruments[index];
    EditCoupling e{index, d.coupling_stiffness, d.coupling_damping, d.force_limit};
    (field == "stiffness" ? e.stiffness : field == "damping" ? e.damping : e.force_limit) = value;
    v.sim.post(e);
    return fmt::format("{}: {} = {} {}", instrument_name(m, index), field, value, f->unit);
  }
  return fmt::format("edit: '{}' is not organ, instrument or contact", kind);
}

namespace {

// A number field: shows the model's value, and on Enter or leaving the field edits it.
void number_field(ViewerState& v, const char* label, std::string_view kind, std::size_t index, std::string_view field,
                  double now, const char* format) {
  static std::string editing;  // the field being typed in keeps its text until it is left
  static double typed = 0.0;
  const std::string id = fmt::format("{}/{}/{}", kind, index, field);
  double shown = editing == id ? typed : now;
  ImGui::InputDouble(label, &shown, 0.0, 0.0, format);
  if (ImGui::IsItemActive()) {
    editing = id;
    typed = shown;
  }
  if (ImGui::IsItemDeactivatedAfterEdit()) {
    v.note(edit_value(v, kind, index, field, shown));
    editing.clear();
  } else if (!ImGui::IsItemActive() && editing == id) {
    editing.clear();
  }
}

double organ_length_now(const ViewerState& v, const ModelInfo::Organ& o) {
  double length = 0.0;
  for (std::size_t s : o.pieces) {
    const Range r = v.model->segment_nodes[s];
    for (std::size_t k = r.offset + 1; k < r.offset + r.count && k < v.node_positions.size(); ++k)
      length += (v.node_positions[k] - v.node_positions[k - 1]).norm();
  }
  return length;
}

void organ_details(ViewerState& v, std::size_t i) {
  const ModelInfo& m = *v.model;
  const ModelInfo::Organ& o = m.organs[i];
  std::size_t nodes = 0, vertices = 0, beads = 0;
  for (std::size_t s : o.pieces) {
    const Range r = m.segment_nodes[s];
    nodes += r.count;
    if (s < m.meshes.size() && m.meshes[s].enabled) vertices += m.meshes[s].vertices.count;
    beads += static_cast<std::size_t>(std::count_if(m.bead_nodes.begin(), m.bead_nodes.end(), [&](std::uint32_t n) {
      return n >= r.offset && n < r.offset + r.count;
    }));
  }
  ImGui::TextWrapped("%s: %zu piece%s, %zu nodes, %zu beads", o.name.c_str(), o.pieces.size(),
                     o.pieces.size() == 1 ? "" : "s", nodes, beads);
  ImGui::Text("length now %.1f mm, radius %.1f mm", 1e3 * organ_length_now(v, o), 1e3 * o.desc.cross_section.radius);
  ImGui::Text("mesh %zu vertices, %zu anchors of tissue", vertices, o.anchors);
  ImGui::Text("density %.0f kg/m3, Poisson %.2f", o.desc.material.density, o.desc.material.poisson_ratio);
  ImGui::TextDisabled("material (the rods rebuilt, meshes kept):");
  number_field(v, "E (Pa)", "organ", i, "youngs_modulus", o.desc.material.youngs_modulus, "%.4g");
  number_field(v, "relaxation (s)", "organ", i, "relaxation_time", o.desc.relaxation_time, "%.3g");
}

void instrument_details(ViewerState& v, std::size_t i) {
  const ModelInfo& m = *v.model;
  const InstrumentDesc& d = m.desc.instruments[i];
  ImGui::TextWrapped("%s: radius %.1f mm, length %.0f mm", instrument_name(m, i).c_str(), 1e3 * d.radius,
                     1e3 * d.length);
  if (i < v.instruments.size()) {
    const InstrumentReading& r = v.instruments[i];
    ImGui::Text("%s, force %.2f N", r.grasping ? "grasping" : r.closed ? "closed" : "open", r.force.norm());
  }
  ImGui::TextDisabled("coupling (from the next step):");
  number_field(v, "stiffness (N/m)", "instrument", i, "stiffness", d.coupling_stiffness, "%.4g");
  number_field(v, "damping (N s/m)", "instrument", i, "damping", d.coupling_damping, "%.3g");
  number_field(v, "force limit (N)", "instrument", i, "force_limit", d.force_limit, "%.3g");
}

void obstacle_details(const ViewerState& v) {
  const EnvironmentDesc& e = v.model->desc.environment;
  const Highlight h = v.draw.highlight;
  const auto vec = [](const Eigen::Vector3d& p) {
    return fmt::format("({:.3f}, {:.3f}, {:.3f})", p.x(), p.y(), p.z());
  };
  if (h.kind == Kind::plane) {
    const PlaneDesc& p = e.planes[h.index];
    ImGui::TextWrapped("plane %s: point %s m, normal %s", p.name.c_str(), vec(p.point).c_str(), vec(p.normal).c_str());
  } else if (h.kind == Kind::sphere) {
    const SphereObstacleDesc& s = e.spheres[h.index];
    ImGui::TextWrapped("sphere %s: centre %s m, radius %.1f mm", s.name.c_str(), vec(s.center).c_str(), 1e3 * s.radius);
  } else if (h.kind == Kind::capsule) {
    const CapsuleObstacleDesc& c = e.capsules[h.index];
    ImGui::TextWrapped("capsule %s: %s to %s m, radius %.1f mm", c.name.c_str(), vec(c.a).c_str(), vec(c.b).c_str(),
                       1e3 * c.radius);
  } else if (h.kind == Kind::mesh) {
    const MeshObstacleDesc& mesh = e.meshes[h.index];
    ImGui::TextWrapped("%s %s: %zu vertices, %zu triangles, from %s", mesh.container ? "container" : "mesh obstacle",
                       mesh.name.c_str(), mesh.vertices.size(), mesh.triangles.size(), mesh.source.c_str());
  }
}

// One selectable line of the tree.
void leaf(ViewerState& v, Kind kind, std::size_t index, const std::string& label) {
  const bool selected = v.draw.highlight == Highlight{kind, index};
  if (ImGui::Selectable(fmt::format("{}##{}{}", label, word_of(kind), index).c_str(), selected))
    v.draw.highlight = selected ? Highlight{} : Highlight{kind, index};
}

void tree(ViewerState& v) {
  const ModelInfo& m = *v.model;
  if (ImGui::TreeNodeEx("organs", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (std::size_t i = 0; i < m.organs.size(); ++i) leaf(v, Kind::organ, i, m.organs[i].name);
    ImGui::TreePop();
  }
  if (ImGui::TreeNodeEx("connective tissue", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (std::size_t i = 0; i < m.organs.size(); ++i)
      if (m.organs[i].anchors > 0)
        leaf(v, Kind::anchors, i, fmt::format("{}: {} anchors", m.organs[i].name, m.organs[i].anchors));
    ImGui::TreePop();
  }
  if (ImGui::TreeNodeEx("instruments", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (std::size_t i = 0; i < m.desc.instruments.size(); ++i) leaf(v, Kind::instrument, i, instrument_name(m, i));
    ImGui::TreePop();
  }
  const EnvironmentDesc& e = m.desc.environment;
  if (e.planes.size() + e.spheres.size() + e.capsules.size() + e.meshes.size() > 0 &&
      ImGui::TreeNodeEx("obstacles", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (std::size_t i = 0; i < e.planes.size(); ++i) leaf(v, Kind::plane, i, "plane " + e.planes[i].name);
    for (std::size_t i = 0; i < e.spheres.size(); ++i) leaf(v, Kind::sphere, i, "sphere " + e.spheres[i].name);
    for (std::size_t i = 0; i < e.capsules.size(); ++i) leaf(v, Kind::capsule, i, "capsule " + e.capsules[i].name);
    for (std::size_t i = 0; i < e.meshes.size(); ++i)
      leaf(v, Kind::mesh, i, (e.meshes[i].container ? "container " : "mesh ") + e.meshes[i].name);
    ImGui::TreePop();
  }
}

void details(ViewerState& v) {
  const Highlight h = v.draw.highlight;
  if (h.kind == Kind::none || h.index >= count_of(*v.model, h.kind)) {
    ImGui::TextDisabled("select a part above: it is highlighted in the view");
  } else if (h.kind == Kind::organ) {
    organ_details(v, h.index);
  } else if (h.kind == Kind::anchors) {
    const ModelInfo::Organ& o = v.model->organs[h.index];
    ImGui::TextWrapped(
        "%s's connective tissue: %zu anchors (lines to their roots; torn and cut ones marked). "
        "Shift-drag on the organ cuts them.",
        o.name.c_str(), o.anchors);
  } else if (h.kind == Kind::instrument) {
    instrument_details(v, h.index);
  } else {
    obstacle_details(v);
  }
  ImGui::Separator();
  ImGui::TextDisabled("contact (the model rebuilt, the state kept):");
  number_field(v, "coefficient", "contact", 0, "coefficient", v.model->desc.contact.coefficient, "%.4g");
}

}  // namespace

void draw_inspector(ViewerState& v) {
  if (!v.inspector_open || !v.model) return;
  const float w = static_cast<float>(v.camera.width), h = static_cast<float>(v.camera.height);
  const float top = v.menu_height + 8.0f;
  ImGui::SetNextWindowPos(ImVec2(std::max(0.0f, w - kInspectorWidth - 8.0f), top), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(kInspectorWidth, std::min(520.0f, h - top - 8.0f)), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("inspector", &v.inspector_open)) {
    ImGui::End();
    return;
  }
  keep_inside(v);
  tree(v);
  ImGui::Separator();
  details(v);
  ImGui::End();
}

}  // namespace haustra::view
