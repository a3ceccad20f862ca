// The stability map of docs/stability.md: outcome of each cell of E, dt, N, load and law.
#include "haustra/studies/stability.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "haustra/error.hpp"
#include "haustra/world.hpp"

namespace haustra::validation {
namespace {

constexpr int kMostContactBeads = 100;

WorldDesc cell_world(const StabilityCell& c, SolverMode mode, InstabilityPolicy policy, int max_substeps) {
  WorldDesc d;
  d.dt = c.dt;
  d.threads = 1;
  d.solver.mode = mode;
  d.solver.on_instability = policy;
  d.solver.max_substeps = max_substeps;
  SegmentDesc s;
  s.name = "rod";
  s.nodes = c.nodes;
  s.rest.length = 1.0;
  s.material.youngs_modulus = c.youngs_modulus;
  if (c.law == "elastic") s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
  if (c.load == "pull") {
    const double ea =
        c.youngs_modulus * 2.0 * std::numbers::pi * s.cross_section.radius * s.cross_section.wall_thickness;
    s.loads.push_back({-1, Eigen::Vector3d(ea, 0.0, 0.0), Eigen::Vector3d::Zero()});  // ε → 1
  }
  if (c.load == "contact") {
    // Lying on a floor whose penalty is a hundred times the paper's (f = 5000 E d²): the beads
    // (every other node, the tube's radius) start just touching it and the weight presses them in.
    // At most one per centimetre: at N = 20,000 every other node would put 10,000 beads 0.1 mm apart,
    // each within the contact margin of a hundred others - a million candidates measuring the
    // broad phase, not the solver.
    s.base_position = {0.0, 0.0, s.cross_section.radius};
    s.beads.enabled = true;
    s.beads.count = std::min((c.nodes + 1) / 2, kMostContactBeads);
    d.contact.coefficient = 5000.0;
    PlaneDesc floor;
    floor.name = "floor";
    d.environment.planes.push_back(floor);
  }
  d.segments.push_back(s);
  return d;
}

bool state_finite(const World& w) {
  const auto p = w.node_positions();
  const auto q = w.strains();
  for (std::size_t k = 0; k < w.node_count(); ++k) {
    if (!p.get(k).allFinite() || !q.get(k).allFinite()) return false;
  }
  return true;
}

// Runs the cell's frames; returns "" when all passed, else the error message.
std::string run_cell(const StabilityCell& c, SolverMode mode, InstabilityPolicy policy, int max_substeps, bool& finite,
                     std::string& event) {
  auto w = World::create(cell_world(c, mode, policy, max_substeps));
  std::string error;
  try {
    for (int f = 0; f < c.frames; ++f) w->step();
  } catch (const Error& e) {
    if (e.code() != ErrorCode::unstable) throw;
    error = e.what();
  }
  finite = state_finite(*w);
  for (const Event& e : w->events())
    if (e.kind == Event::Kind::recovered) {
      event = std::string(e.message());
      break;
    }
  return error;
}

bool names_cause(const std::string& error) {
  return error.find("segment '") != std::string::npos && error.find("node ") != std::string::npos &&
         error.find("after stage '") != std::string::npos;
}

}  // namespace

StabilityOptions stability_large_n_options() {
  StabilityOptions o;
  o.youngs_moduli = {10.0, 33.2e3, 1e7};
  o.time_steps = {1e-4, 0.1};
  o.nodes = {20000};
  o.frames_large = 3;
  o.max_substeps = 2;
  return o;
}

namespace {
std::string load_title(const std::string& load) {
  if (load == "gravity") return "Gravity load";
  if (load == "pull") return "Gravity + tip pull to 100 % strain";
  return "Gravity, lying on a stiff floor (100× the paper's contact penalty)";
}
}  // namespace

std::vector<StabilityCell> stability_cells(const StabilityOptions& o) {
  std::vector<StabilityCell> cells;
  for (int n : o.nodes)
    for (const std::string& load : o.loads)
      for (const char* law : {"viscous", "elastic"})
        for (double e : o.youngs_moduli)
          for (double dt : o.time_steps) {
            StabilityCell c;
            c.youngs_modulus = e;
            c.dt = dt;
            c.nodes = n;
            c.load = load;
            c.law = law;
            c.frames = n > 200 ? o.frames_large : o.frames_small;
            cells.push_back(c);
          }
  return cells;
}

StabilityCell run_stability_cell(StabilityCell c, const StabilityOptions& o) {
  std::string event;
  bool finite = true;
  const std::string lagged_error =
      run_cell(c, SolverMode::lagged, InstabilityPolicy::stop, o.max_substeps, finite, event);
  c.finite = finite;
  if (lagged_error.empty()) {
    c.outcome = "lagged";
  } else {
    std::string robust_event;
    const std::string robust_error =
        run_cell(c, SolverMode::lagged, InstabilityPolicy::recover, o.max_substeps, finite, robust_event);
    c.finite = c.finite && finite;
    if (robust_error.empty()) {
      c.outcome = "robust";
      c.detail = robust_event;
    } else {
      c.outcome = "error";
      c.detail = robust_error;
      c.names_cause = names_cause(robust_error);
    }
  }
  if (o.fast) {
    std::string fast_event;
    const std::string fast_error =
        run_cell(c, SolverMode::fast, InstabilityPolicy::recover, o.max_substeps, finite, fast_event);
    c.finite = c.finite && finite;
    c.fast_outcome = !fast_error.empty() ? "error" : (fast_event.empty() ? "fast" : "robust");
    c.fast_detail = fast_error.empty() ? fast_event : fast_error;
    if (!fast_error.empty()) c.names_cause = c.names_cause && names_cause(fast_error);
  }
  return c;
}

std::vector<StabilityCell> stability_sweep(const StabilityOptions& o) {
  std::vector<StabilityCell> cells = stability_cells(o);
  for (StabilityCell& c : cells) c = run_stability_cell(c, o);
  return cells;
}

constexpr const char* kStabilityIntro = R"md(# Stability map

What the extremes do. The rod is the paper's rectum (R = 2 cm, 3 mm wall, ν = 0.35,
1050 kg/m³), 1 m long, clamped horizontally at one end, under gravity; the "pull" load adds a tip
force EA along the rod (100 % strain at equilibrium); the "stiff floor" load lays the rod, with a
bead on every other node (at most 100, one per centimetre), on a floor whose penalty is 100× the
paper's (f = 5000 E d²). The heat map `docs/figures/stability-map.png` shows the same cells. Each cell runs 30 frames (N ≤ 200) or 6
frames (N = 2000; 3 frames at N = 20,000) first with the paper's lagged scheme alone
(`on_instability = "stop"`), then, if that failed, with the robust mode (`"recover"`: Newton, then
Newton with 2, 4, 8 substeps).

- **ok** — the lagged scheme is stable there.
- **robust** — the lagged scheme diverged (the guard saw it), the robust mode recovered.
- **error** — neither could: the run stopped with an error naming segment, node, stage and cause,
  and kept its last good frame.

After the slash, the same cell in **fast mode** (`solver.mode = "fast"`, decision 0037: Newton
reusing its factorization, one iteration a frame, its potential not weighed) with the robust mode
behind it: **ok** — it held on its own; **robust** — the guard had frames redone by full Newton;
**error** — stopped with a named cause.

No cell ended with a non-finite value. Regenerate this file with `make stability-doc`
(`haustra stability --markdown --csv tests/data/stability-map.csv > docs/stability.md`, then
`scripts/plots.py stability`); the tests `stability sweep` run the cells again and assert each one's
outcome, lagged and fast, against that committed table (the stiff floor at N ≤ 20 there; the whole
map takes under a minute on one core).

What the map says:

- The paper's scheme is only stable where bending stiffness dominates the loads: stiff material,
  short steps, or few nodes. With the paper's own parameters (E = 33.2 kPa) a 1 m rod hanging
  under gravity diverges at 60 Hz; a pull to 100 % strain makes it diverge almost everywhere,
  because tension is a load stiffness (F L²/B) the lagged iteration cannot follow.
- Newton recovers every such cell where the load is physically sustainable.
- The *error* cells are loads the material cannot carry: E ≤ 1 kPa (a rod softer than jelly) with
  its own weight or a pull stretches it past the guard's 400 % or crushes a section to less than a
  tenth of its length — the error says "axial strain … exceeds the limit" or "compression (−axial
  strain) of a collapsing section …". Those are bad inputs, not solver failures.
- At N = 20,000 the same holds; Newton's cost is linear in N. (A stiff contact there can stop
  robust Newton with a pivot too small: beyond 4096 nodes there is no banded fallback.)
- Fast mode, with the robust mode behind it, holds wherever the robust mode does under gravity and
  a pull, save two cells; on the stiff floor it stops in fewer cells than lagged-then-Newton
  (counts below the tables), the guard redoing its frames with Newton in many of them.
- **A stiff contact is what the quasi-static scheme handles worst.** Lying on a floor whose penalty
  is 100× the paper's, most cells above Δt = 0.1 ms need the robust mode or stop, even for stiff
  rods: the guard stops them for a section collapsing under the floor's push ("compression … of a
  collapsing section"), beads pressed deeper than the limit into the floor, or a frame that gains
  energy no work put in (docs/reliability.md). None ends in NaN. The paper's own penalty (the other tables, and every
  scene) is the setting this engine is tuned for; stiffer contacts need shorter steps.
)md";

std::string stability_markdown(const std::vector<StabilityCell>& cells) {
  std::string md = kStabilityIntro;
  md += "\n## Tables\n";
  auto symbol = [](const StabilityCell& c) {
    if (!c.finite) return std::string("**NaN**");
    std::string s = c.outcome == "lagged" ? "ok" : (c.outcome == "robust" ? "robust" : "error");
    if (!c.fast_outcome.empty()) s += " / " + std::string(c.fast_outcome == "fast" ? "ok" : c.fast_outcome);
    return s;
  };
  std::vector<int> nodes;
  std::vector<double> es, dts;
  for (const auto& c : cells) {
    if (std::find(nodes.begin(), nodes.end(), c.nodes) == nodes.end()) nodes.push_back(c.nodes);
    if (std::find(es.begin(), es.end(), c.youngs_modulus) == es.end()) es.push_back(c.youngs_modulus);
    if (std::find(dts.begin(), dts.end(), c.dt) == dts.end()) dts.push_back(c.dt);
  }
  for (const char* load : {"gravity", "pull", "contact"})
    for (const char* law : {"viscous", "elastic"}) {
      md += fmt::format("\n### {}; {} bending and torsion\n\n", load_title(load), law);
      md += "| N | E (Pa) |";
      for (double dt : dts) md += fmt::format(" Δt = {:g} s |", dt);
      md += "\n|---|---|";
      for (std::size_t i = 0; i < dts.size(); ++i) md += "---|";
      md += "\n";
      for (int n : nodes)
        for (double e : es) {
          std::string row = fmt::format("| {} | {:g} |", n, e);
          bool any = false;
          for (double dt : dts) {
            const auto it = std::find_if(cells.begin(), cells.end(), [&](const StabilityCell& c) {
              return c.nodes == n && c.youngs_modulus == e && c.dt == dt && c.load == load && c.law == law;
            });
            row += it == cells.end() ? std::string(" |") : fmt::format(" {} |", symbol(*it));
            any = any || it != cells.end();
          }
          if (any) md += row + "\n";
        }
    }
  // Why cells failed, grouped by the guard's reason.
  std::map<std::string, int> reasons;
  for (const auto& c : cells) {
    if (c.outcome != "error") continue;
    const std::size_t colon = c.detail.find(": ", c.detail.find("node "));
    const std::size_t after = c.detail.find(" after stage");
    std::string reason = colon != std::string::npos && after != std::string::npos
                             ? c.detail.substr(colon + 2, after - colon - 2)
                             : c.detail;
    // Drop the numbers so that equal reasons group.
    std::string key;
    for (char ch : reason)
      key += (std::isdigit(static_cast<unsigned char>(ch)) != 0 || ch == '.' || ch == '-') ? '#' : ch;
    std::string collapsed;
    for (char ch : key)
      if (!(ch == '#' && !collapsed.empty() && collapsed.back() == '#')) collapsed += ch;
    reasons[collapsed] += 1;
  }
  if (!reasons.empty()) {
    md += "\nCells marked *error* stopped with these causes (numbers elided):\n\n";
    for (const auto& [r, count] : reasons) md += fmt::format("- {} × {}\n", count, r);
  }
  // The fast mode against the lagged scheme and Newton, cell by cell.
  int fast_ok = 0, fast_robust = 0, fast_error = 0, worse = 0, runs = 0;
  for (const auto& c : cells) {
    if (c.fast_outcome.empty()) continue;
    ++runs;
    fast_ok += c.fast_outcome == "fast";
    fast_robust += c.fast_outcome == "robust";
    fast_error += c.fast_outcome == "error";
    worse += c.fast_outcome == "error" && c.outcome != "error";
  }
  if (runs > 0)
    md += fmt::format(
        "\nFast mode over the {} cells: {} held on their own, {} had frames redone by Newton, {} stopped ({} of "
        "them where the lagged scheme or the robust mode did not: fast mode's own failures).\n",
        runs, fast_ok, fast_robust, fast_error, worse);
  return md;
}

}  // namespace haustra::validation
