// The speed/accuracy study (docs/tradeoff.md): its knobs run in turn (tradeoff_*_knobs.cpp), the
// Pareto front of each, and the CSV and Markdown written from them.
#include "haustra/studies/tradeoff_study.hpp"

#include <fmt/format.h>

#include <chrono>

#include "haustra/error.hpp"
#include "tradeoff_knobs.hpp"

namespace haustra::validation {
namespace {

using Clock = std::chrono::steady_clock;
using namespace tradeoff;

// Settings no other setting beats in both error and cost.
std::vector<bool> pareto(const TradeoffKnob& k) {
  std::vector<bool> front(k.rows.size(), k.pareto);
  if (!k.pareto) return front;
  for (std::size_t i = 0; i < k.rows.size(); ++i)
    for (std::size_t j = 0; j < k.rows.size(); ++j) {
      const TradeoffRow& a = k.rows[i];
      const TradeoffRow& b = k.rows[j];
      if (i != j && b.error <= a.error && b.cost_us <= a.cost_us && (b.error < a.error || b.cost_us < a.cost_us))
        front[i] = false;
    }
  return front;
}

// Hooke against EXP2: what the simplification misses, up to and beyond the paper's 25 %.
std::string exp2_guide_line(const TradeoffKnob& k) {
  // Hooke against EXP2: what the simplification misses, up to and beyond the paper's 25 %.
  double gentle = 0.0, hard = 0.0, hooke_cost = 0.0, exp2_cost = 0.0;
  std::string worst_gentle, worst_hard;
  for (const TradeoffRow& r : k.rows) {
    const bool hooke = r.setting.rfind("Hooke", 0) == 0;
    (hooke ? hooke_cost : exp2_cost) = r.cost_us;
    if (!hooke) continue;
    const bool beyond = r.setting.find("40 %") != std::string::npos || r.setting.find("60 %") != std::string::npos;
    double& worst = beyond ? hard : gentle;
    if (r.error > worst) {
      worst = r.error;
      (beyond ? worst_hard : worst_gentle) = r.setting.substr(7);
    }
  }
  return fmt::format(
      "- **{}**: up to 25 % strain Hooke's law misses the EXP2 equilibrium by up to {:.3g} mm ({}) on the "
      "0.2 m rod, beyond it by up to {:.3g} mm ({}); EXP2 costs {:.2f}× Hooke's frame. With measured EXP2 "
      "parameters use EXP2 in both loops — it costs next to nothing; Hooke's one modulus is the choice only when "
      "that is all that is known. (The parameters here are illustrative: the paper gives none.)\n",
      k.name, gentle, worst_gentle, hard, worst_hard, hooke_cost > 0.0 ? exp2_cost / hooke_cost : 0.0);
}

// The guide's line for a knob: the haptic pick within its threshold and the offline pick; a knob
// with no threshold (not a speed knob) says what its note says.
std::string guide_line(const TradeoffKnob& k) {
  if (k.name == "tissue law: Hooke against EXP2") return exp2_guide_line(k);
  if (k.haptic_error <= 0.0) return fmt::format("- **{}**: {}.\n", k.name, k.guide_note);
  const TradeoffRow* best = &k.rows[0];
  for (const TradeoffRow& r : k.rows)
    if (r.error < best->error) best = &r;
  const TradeoffRow* haptic = nullptr;
  const TradeoffRow* cheapest = nullptr;
  for (const TradeoffRow& r : k.rows) {
    if (r.is_reference) continue;
    if (cheapest == nullptr || r.cost_us < cheapest->cost_us) cheapest = &r;
    if (r.error <= k.haptic_error && (haptic == nullptr || r.cost_us < haptic->cost_us)) haptic = &r;
  }
  std::string line = fmt::format(
      "- **{}**: haptic loop — {}; offline — {} ({} {:.3g}, {:.4g} µs).\n", k.name,
      haptic == nullptr
          ? fmt::format("none within {:g} ({}); the cheapest, {}, misses by {:.3g}", k.haptic_error, k.error_name,
                        cheapest != nullptr ? cheapest->setting : "—", cheapest != nullptr ? cheapest->error : 0.0)
          : fmt::format("{} ({} {:.3g} ≤ {:g}, {:.4g} µs)", haptic->setting, k.error_name, haptic->error,
                        k.haptic_error, haptic->cost_us),
      best->setting, k.error_name, best->error, best->cost_us);
  if (!k.guide_note.empty()) line += fmt::format("  *Note:* {}.\n", k.guide_note);
  return line;
}

}  // namespace

namespace {
using KnobFunction = TradeoffKnob (*)();
const std::vector<std::pair<std::string, KnobFunction>>& knob_functions() {
  static const std::vector<std::pair<std::string, KnobFunction>> knobs = {
      {"nodes per segment", knob_nodes},         {"beads per node", knob_beads},
      {"iterations per frame", knob_iterations}, {"inertia filter", knob_filter},
      {"Hooke against EXP2", knob_exp2},         {"the skin", knob_rings},
      {"float against double", knob_precision},  {"exponential against midpoint", knob_integrator},
      {"grasp coupling", knob_coupling},         {"sleeping rods", knob_sleep},
      {"sleeping ranges", knob_sleep_ranges}};
  return knobs;
}
}  // namespace

std::vector<std::string> tradeoff_knob_names() {
  std::vector<std::string> names;
  for (const auto& [name, run] : knob_functions()) names.push_back(name);
  return names;
}

TradeoffKnob run_tradeoff_knob(const std::string& name) {
  for (const auto& [known, run] : knob_functions())
    if (known == name) return run();
  std::string names;
  for (const auto& [known, run] : knob_functions()) names += (names.empty() ? "'" : ", '") + known + "'";
  throw Error(ErrorCode::invalid_argument,
              fmt::format("trade-off study: no knob '{}' (expected one of {})", name, names));
}

TradeoffStudy run_tradeoff_study(const std::function<void(const std::string&)>& progress) {
  const auto start = Clock::now();
  TradeoffStudy s;
  for (const std::string& name : tradeoff_knob_names()) {
    if (progress) progress(name);
    s.knobs.push_back(run_tradeoff_knob(name));
  }
  s.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return s;
}

std::string tradeoff_csv(const TradeoffStudy& study) {
  std::string out = "knob,setting,error,error_name,cost_us,cost_name,pareto,default\n";
  auto quoted = [](const std::string& s) { return "\"" + s + "\""; };
  for (const TradeoffKnob& k : study.knobs) {
    const std::vector<bool> front = pareto(k);
    for (std::size_t i = 0; i < k.rows.size(); ++i) {
      const TradeoffRow& r = k.rows[i];
      out += fmt::format("{},{},{:.6g},{},{:.6g},{},{},{}\n", quoted(k.name), quoted(r.setting), r.error,
                         quoted(k.error_name), r.cost_us, quoted(k.cost_name), front[i] ? 1 : 0, r.is_default ? 1 : 0);
    }
  }
  return out;
}

std::string tradeoff_markdown(const TradeoffStudy& study) {
  std::string md =
      "# Speed against accuracy\n\n"
      "<!-- Generated by `make study` (haustra study --markdown); edit studies/src/tradeoff_study.cpp. -->\n\n"
      "Every simplification the paper made, and a few of ours, as a knob: each setting's error against a "
      "stated reference, and what it costs per frame on this machine (one thread, the engine's own "
      "frame timer or the median of repeated runs of the stage the knob changes). The machine is "
      "shared and noisy: costs are good to ~20 %, errors are deterministic. ● marks the Pareto front "
      "(no other setting of the knob is both cheaper and more accurate).\n\n"
      "![error against cost per knob, Pareto fronts joined](figures/tradeoff.png)\n\n"
      "Where each scheme holds as E, Δt, N and the load vary (gravity, a pull, a stiff contact) is "
      "mapped in [stability.md](stability.md) (`make stability-doc`).\n\n"
      "## Guide\n\n"
      "Picked from the tables below by rule, not by hand: for a **haptic loop** (1 kHz, every "
      "microsecond counts) the cheapest setting within the error stated; for an **offline accuracy "
      "check** the most accurate setting measured.\n\n";
  for (const TradeoffKnob& k : study.knobs)
    if (!k.rows.empty()) md += guide_line(k);
  md += "\n## Knobs\n\n";
  for (const TradeoffKnob& k : study.knobs) {
    const std::vector<bool> front = pareto(k);
    md += fmt::format("### {}\n\n", k.name);
    md += fmt::format("*Run:* {}.  \n*Reference:* {}.\n\n", k.scene, k.reference);
    if (k.haptic_error > 0.0)
      md += fmt::format("Guide's haptic threshold: {} ≤ {:g}.\n\n", k.error_name, k.haptic_error);
    md += fmt::format("| setting | {} | {} | Pareto | further |\n|---|---:|---:|:-:|---|\n", k.error_name, k.cost_name);
    for (std::size_t i = 0; i < k.rows.size(); ++i) {
      const TradeoffRow& r = k.rows[i];
      const std::string error = r.is_reference ? "0 (reference)" : fmt::format("{:.3g}", r.error);
      md += fmt::format("| {}{} | {} | {:.4g} | {} | {} |\n", r.setting, r.is_default ? " **(default)**" : "", error,
                        r.cost_us, front[i] ? "●" : "", r.details);
    }
    md += "\n";
  }
  md += fmt::format("The whole study ran in {:.0f} s on one thread.\n", study.seconds);
  return md;
}

}  // namespace haustra::validation
