// haustra._haustra._studies: one cell of the stability map and one knob of the trade-off study,
// for the Dask studies (python/haustra/studies, decision 0070) — the same C++ functions the
// `haustra stability` and `haustra study` sweeps run, so the tables match bit for bit.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "haustra/studies/stability.hpp"
#include "haustra/studies/tradeoff_study.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

using validation::StabilityCell;
using validation::StabilityOptions;
using validation::TradeoffKnob;
using validation::TradeoffRow;

// The sweep `haustra stability` runs first, or its N = 20,000 corner (large_n).
StabilityOptions stability_options(bool large_n) {
  return large_n ? validation::stability_large_n_options() : StabilityOptions{};
}

py::dict stability_dict(const StabilityCell& c) {
  py::dict d;
  d["youngs_modulus"] = c.youngs_modulus;
  d["dt"] = c.dt;
  d["nodes"] = c.nodes;
  d["load"] = c.load;
  d["law"] = c.law;
  d["frames"] = c.frames;
  d["outcome"] = c.outcome;
  d["detail"] = c.detail;
  d["finite"] = c.finite;
  d["names_cause"] = c.names_cause;
  d["fast_outcome"] = c.fast_outcome;
  d["fast_detail"] = c.fast_detail;
  return d;
}

// Reads back what stability_dict wrote (a row of a study's table); parameters are required, the
// outcome fields optional (a cell not yet run has none).
StabilityCell stability_cell_of(const py::dict& d) {
  StabilityCell c;
  c.youngs_modulus = d["youngs_modulus"].cast<double>();
  c.dt = d["dt"].cast<double>();
  c.nodes = d["nodes"].cast<int>();
  c.load = d["load"].cast<std::string>();
  c.law = d["law"].cast<std::string>();
  c.frames = d["frames"].cast<int>();
  if (d.contains("outcome")) c.outcome = d["outcome"].cast<std::string>();
  if (d.contains("detail")) c.detail = d["detail"].cast<std::string>();
  if (d.contains("finite")) c.finite = d["finite"].cast<bool>();
  if (d.contains("names_cause")) c.names_cause = d["names_cause"].cast<bool>();
  if (d.contains("fast_outcome")) c.fast_outcome = d["fast_outcome"].cast<std::string>();
  if (d.contains("fast_detail")) c.fast_detail = d["fast_detail"].cast<std::string>();
  return c;
}

py::dict knob_dict(const TradeoffKnob& k) {
  py::list rows;
  for (const TradeoffRow& r : k.rows) {
    py::dict row;
    row["setting"] = r.setting;
    row["error"] = r.error;
    row["cost_us"] = r.cost_us;
    row["details"] = r.details;
    row["is_default"] = r.is_default;
    row["is_reference"] = r.is_reference;
    rows.append(row);
  }
  py::dict d;
  d["name"] = k.name;
  d["scene"] = k.scene;
  d["reference"] = k.reference;
  d["error_name"] = k.error_name;
  d["cost_name"] = k.cost_name;
  d["haptic_error"] = k.haptic_error;
  d["pareto"] = k.pareto;
  d["guide_note"] = k.guide_note;
  d["rows"] = rows;
  return d;
}

TradeoffKnob knob_of(const py::dict& d) {
  TradeoffKnob k;
  k.name = d["name"].cast<std::string>();
  k.scene = d["scene"].cast<std::string>();
  k.reference = d["reference"].cast<std::string>();
  k.error_name = d["error_name"].cast<std::string>();
  k.cost_name = d["cost_name"].cast<std::string>();
  k.haptic_error = d["haptic_error"].cast<double>();
  k.pareto = d["pareto"].cast<bool>();
  k.guide_note = d["guide_note"].cast<std::string>();
  for (const py::handle item : d["rows"].cast<py::list>()) {
    const py::dict row = item.cast<py::dict>();
    k.rows.push_back({row["setting"].cast<std::string>(), row["error"].cast<double>(), row["cost_us"].cast<double>(),
                      row["details"].cast<std::string>(), row["is_default"].cast<bool>(),
                      row["is_reference"].cast<bool>()});
  }
  return k;
}

validation::TradeoffStudy study_of(const py::list& knobs, double seconds) {
  validation::TradeoffStudy s;
  for (const py::handle k : knobs) s.knobs.push_back(knob_of(k.cast<py::dict>()));
  s.seconds = seconds;
  return s;
}

std::vector<StabilityCell> cells_of(const py::list& cells) {
  std::vector<StabilityCell> out;
  for (const py::handle c : cells) out.push_back(stability_cell_of(c.cast<py::dict>()));
  return out;
}

}  // namespace

void bind_studies(py::module_& m) {
  py::module_ s = m.def_submodule("_studies", "The cells of the project's own studies (haustra.studies runs them).");
  s.def(
      "stability_cells",
      [](bool large_n) {
        py::list out;
        for (const StabilityCell& c : validation::stability_cells(stability_options(large_n)))
          out.append(stability_dict(c));
        return out;
      },
      py::arg("large_n") = false, "The stability map's cells in the sweep's order, parameters only.");
  s.def(
      "run_stability_cell",
      [](const py::dict& cell, bool large_n) {
        StabilityCell c = stability_cell_of(cell);
        {
          py::gil_scoped_release release;
          c = validation::run_stability_cell(c, stability_options(large_n));
        }
        return stability_dict(c);
      },
      py::arg("cell"), py::arg("large_n") = false, "One cell run as `haustra stability` runs it.");
  s.def(
      "stability_markdown", [](const py::list& cells) { return validation::stability_markdown(cells_of(cells)); },
      py::arg("cells"), "docs/stability.md from the cells, in the sweep's order.");
  s.def("tradeoff_knob_names", &validation::tradeoff_knob_names);
  s.def(
      "run_tradeoff_knob",
      [](const std::string& name) {
        TradeoffKnob k;
        {
          py::gil_scoped_release release;
          k = validation::run_tradeoff_knob(name);
        }
        return knob_dict(k);
      },
      py::arg("name"), "One knob of the speed/accuracy study, every setting measured.");
  s.def(
      "tradeoff_markdown",
      [](const py::list& knobs, double seconds) { return validation::tradeoff_markdown(study_of(knobs, seconds)); },
      py::arg("knobs"), py::arg("seconds"), "docs/tradeoff.md from the knobs, in the study's order.");
  s.def(
      "tradeoff_csv", [](const py::list& knobs) { return validation::tradeoff_csv(study_of(knobs, 0.0)); },
      py::arg("knobs"), "The CSV `haustra study --csv` writes.");
}

}  // namespace haustra::python
