#pragma once
// The stability map: the paper's rectum rod (R = 2 cm, 3 mm wall, 1 m, clamped horizontal) across
// Young's modulus, time step, node count and load, first with the lagged scheme alone, then with
// the robust mode. Every run must end finite: stable, recovered, or stopped with a named cause.
#include <string>
#include <vector>

namespace haustra::validation {

struct StabilityCell {
  double youngs_modulus = 0.0;  // Pa
  double dt = 0.0;              // s
  int nodes = 0;
  std::string load;  // "gravity", "pull" (gravity + a tip pull to 100% strain) or "contact"
                     // (gravity, lying on a floor with 100× the paper's penalty)
  std::string law;   // "elastic" or "viscous" (bending and torsion; axial elastic)
  int frames = 0;
  std::string outcome;      // "lagged" (stable as the paper runs it), "robust", "error"
  std::string detail;       // the robust mode's event, or the error
  bool finite = true;       // every node position and strain finite at the end
  bool names_cause = true;  // an error names segment, node and stage
  // The fast mode (decision 0037) in the same cell, with the robust mode behind it: "fast" (held
  // on its own), "robust" (the guard had frames redone by Newton), "error"; "" when not run.
  std::string fast_outcome;
  std::string fast_detail;
};

struct StabilityOptions {
  std::vector<double> youngs_moduli = {10.0, 1e3, 33.2e3, 1e6, 1e7};
  std::vector<double> time_steps = {1e-4, 1e-3, 1.0 / 60.0, 0.1};
  std::vector<int> nodes = {2, 20, 167, 2000};
  int frames_small = 30;  // N ≤ 200
  int frames_large = 6;   // N > 200
  int max_substeps = 8;   // the robust ladder: lagged, Newton, Newton with 2, 4, 8 substeps
  std::vector<std::string> loads = {"gravity", "pull", "contact"};
  bool fast = true;  // also run each cell in fast mode
};

// The cells of the sweep, in its order, with only their parameters (E, dt, N, load, law, frames)
// set; one cell run (its outcome filled in): what the sweep does for each, and what a study on
// Dask runs as one task (python/haustra/studies, decision 0070).
std::vector<StabilityCell> stability_cells(const StabilityOptions& options);
StabilityCell run_stability_cell(StabilityCell cell, const StabilityOptions& options);
std::vector<StabilityCell> stability_sweep(const StabilityOptions& options);

// The N = 20,000 corner: softest, paper and stiffest material at the extreme time steps.
StabilityOptions stability_large_n_options();

// Markdown: one table per load and law, E × Δt cells per N.
std::string stability_markdown(const std::vector<StabilityCell>& cells);

}  // namespace haustra::validation
