#pragma once
// The speed-against-accuracy study of docs/tradeoff.md (`haustra study`, `make study`): each of
// the paper's simplifications as a knob, each setting measured for its error against a stated
// reference and for its cost per frame, on this machine, one thread.
#include <functional>
#include <string>
#include <vector>

namespace haustra::validation {

struct TradeoffRow {
  std::string setting;        // "N = 167", "every 3rd node", "Newton, 2 iterations"
  double error = 0.0;         // in the knob's error unit
  double cost_us = 0.0;       // µs per frame (or of the stage the knob changes; see the knob's cost)
  std::string details;        // further measurements, as text
  bool is_default = false;    // what the engine does unless told otherwise
  bool is_reference = false;  // the reference itself (error 0 by definition): never the guide's pick
};

struct TradeoffKnob {
  std::string name;        // "nodes per segment"
  std::string scene;       // what was run
  std::string reference;   // what the error is measured against
  std::string error_name;  // "tip error (mm)"
  std::string cost_name;   // "frame (µs)" or the stage it changes
  std::vector<TradeoffRow> rows;
  // The guide's haptic pick: the cheapest setting within this error (0: no pick, see the table).
  double haptic_error = 0.0;
  bool pareto = true;        // false where the rows are not alternatives (different loads)
  std::string guide_note{};  // what the rule cannot see, added to the guide's line
};

struct TradeoffStudy {
  std::vector<TradeoffKnob> knobs;
  double seconds = 0.0;
};

// The knobs' names in the study's order, and one knob run (an unknown name is refused, the names
// listed): what the study runs in turn, and what a study on Dask runs as one task (decision 0070).
std::vector<std::string> tradeoff_knob_names();
TradeoffKnob run_tradeoff_knob(const std::string& name);

// progress: called with each knob's name as it starts (for the command line), may be empty.
TradeoffStudy run_tradeoff_study(const std::function<void(const std::string&)>& progress = {});
std::string tradeoff_markdown(const TradeoffStudy& study);
std::string tradeoff_csv(const TradeoffStudy& study);

}  // namespace haustra::validation
