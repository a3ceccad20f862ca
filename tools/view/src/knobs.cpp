// Knob changes as description edits, with the words the panel, the script and the log share.
#include "knobs.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>

#include "haustra/error.hpp"

namespace haustra::view {
namespace {

[[noreturn]] void refuse(std::string_view name, std::string_view value, std::string_view expected) {
  throw Error(ErrorCode::invalid_argument, fmt::format("knob {}: '{}' is not {}", name, value, expected));
}

double number(std::string_view name, std::string_view value) {
  double x = 0.0;
  const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), x);
  if (ec != std::errc() || end != value.data() + value.size() || !std::isfinite(x)) refuse(name, value, "a number");
  return x;
}

}  // namespace

double beads_per_node(const WorldDesc& desc) {
  for (const SegmentDesc& s : desc.segments)
    if (s.beads.enabled && s.beads.count > 0) return static_cast<double>(s.beads.count) / s.nodes;
  return 0.0;
}

std::string skin_name(SkinningMethod m) {
  return std::string(kSkinNames[static_cast<std::size_t>(std::find(kSkins.begin(), kSkins.end(), m) - kSkins.begin())]);
}

std::string knob_value(const WorldDesc& d, std::string_view name) {
  if (name == "mode") return solver_mode_name(d.solver.mode);
  if (name == "iterations") return std::to_string(d.solver.iterations);
  if (name == "filter") return d.filter.enabled ? "on" : "off";
  if (name == "law")
    return !d.segments.empty() && d.segments[0].material.response == TissueResponse::exp2 ? "exp2" : "hooke";
  if (name == "beads_per_node") return fmt::format("{:.3g}", beads_per_node(d));
  if (name == "skin") return d.segments.empty() ? "along-rod" : skin_name(d.segments[0].mesh.skinning);
  if (name == "gravity") return fmt::format("{} {} {}", d.gravity.x(), d.gravity.y(), d.gravity.z());
  if (name == "contact") return fmt::format("{:.4g}", d.contact.coefficient);
  if (name == "rate") return std::abs(d.dt - 1e-3) < 1e-12 ? "1khz" : fmt::format("{:.4g} s", d.dt);
  return "?";
}

KnobChange set_knob(const WorldDesc& now, std::string_view name, std::string_view value, double scene_dt) {
  KnobChange c{now, ""};
  WorldDesc& d = c.desc;
  if (name == "mode") {
    if (value == "lagged")
      d.solver.mode = SolverMode::lagged;
    else if (value == "newton")
      d.solver.mode = SolverMode::newton;
    else if (value == "fast")
      d.solver.mode = SolverMode::fast;
    else
      refuse(name, value, "lagged, newton or fast");
  } else if (name == "iterations") {
    const double n = number(name, value);
    if (n < 1 || n > 64 || n != std::floor(n)) refuse(name, value, "a whole number from 1 to 64");
    d.solver.iterations = static_cast<int>(n);
    d.solver.max_iterations = std::max(d.solver.max_iterations, d.solver.iterations);
  } else if (name == "filter") {
    if (value != "on" && value != "off") refuse(name, value, "on or off");
    d.filter.enabled = value == "on";
  } else if (name == "law") {
    if (value != "hooke" && value != "exp2") refuse(name, value, "hooke or exp2");
    for (SegmentDesc& s : d.segments)
      s.material.response = value == "exp2" ? TissueResponse::exp2 : TissueResponse::hooke;
  } else if (name == "beads_per_node") {
    const double x = number(name, value);
    if (x <= 0.0 || x > 1.0) refuse(name, value, "a number in (0, 1]");
    for (SegmentDesc& s : d.segments) {
      if (!s.beads.enabled) continue;
      s.beads.count = std::max(2, static_cast<int>(std::lround(x * s.nodes)));
      s.beads.spacing = 0.0;
      s.beads.nodes.clear();
    }
  } else if (name == "skin") {  // decision 0120: the scene's mesh.skinning
    const auto it = std::find(kSkinNames.begin(), kSkinNames.end(), value);
    if (it == kSkinNames.end()) refuse(name, value, "along-rod, cage, cage-full or linear-blend");
    for (SegmentDesc& s : d.segments) s.mesh.skinning = kSkins[static_cast<std::size_t>(it - kSkinNames.begin())];
  } else if (name == "gravity") {
    std::istringstream in{std::string(value)};
    double x = 0, y = 0, z = 0;
    if (!(in >> x >> y >> z) || !std::isfinite(x + y + z)) refuse(name, value, "three numbers, m/s²");
    d.gravity = {x, y, z};
  } else if (name == "contact") {
    const double x = number(name, value);
    if (x <= 0.0 || x > 1e6)
      refuse(name, value, "a contact coefficient in (0, 1e6] (f = coefficient x E x depth^exponent)");
    d.contact.coefficient = x;
  } else if (name == "rate") {
    if (value == "1khz")
      d.dt = 1e-3;
    else if (value == "scene")
      d.dt = scene_dt;
    else
      refuse(name, value, "scene or 1khz");
  } else {
    throw Error(
        ErrorCode::invalid_argument,
        fmt::format("no knob '{}' (mode, iterations, filter, law, beads_per_node, rings, gravity, contact, rate)",
                    name));
  }
  c.what = fmt::format("{} {} -> {}", name, knob_value(now, name), knob_value(d, name));
  return c;
}

}  // namespace haustra::view
