#pragma once
// The reference cases of the foundation: each builds a world through the public C++ API, runs it,
// and compares one number with an independent reference (references.hpp) under a stated
// tolerance. `haustra validate` prints them; the doctest suite asserts them.
#include <filesystem>
#include <string>
#include <vector>

#include "haustra/world_desc.hpp"

namespace haustra::validation {

struct CaseResult {
  std::string name;      // what was run
  std::string quantity;  // what was compared, with units
  double reference = 0.0;
  double value = 0.0;
  double error = 0.0;  // relative unless `absolute`
  double tolerance = 0.0;
  bool absolute = false;  // error is absolute (same units as the quantity)
  bool pass = false;
  std::string note;
};

struct Options {
  std::filesystem::path assets = HAUSTRA_DEFAULT_ASSETS;  // where the A-DSJ centreline lives
};

// One reference comparison: relative error |value − reference| / |reference| (absolute:
// |value − reference|), passing when it is within the tolerance. Every case below goes through these.
CaseResult compare(std::string name, std::string quantity, double reference, double value, double tolerance,
                   std::string note = {});
CaseResult compare_absolute(std::string name, std::string quantity, double reference, double value, double tolerance,
                            std::string note = {});

std::vector<CaseResult> axial_end_force(SolverMode mode);
std::vector<CaseResult> pure_end_moment(SolverMode mode);
std::vector<CaseResult> end_torque(SolverMode mode);
std::vector<CaseResult> cantilever_small_load(SolverMode mode);
std::vector<CaseResult> cantilever_large_load(SolverMode mode);
std::vector<CaseResult> cantilever_convergence(SolverMode mode);
std::vector<CaseResult> viscous_constant_moment(SolverMode mode);
std::vector<CaseResult> held_both_ends_elastic(SolverMode mode);
std::vector<CaseResult> held_both_ends_viscous(SolverMode mode);
std::vector<CaseResult> centreline_rest_shape(const Options& options, SolverMode mode);

std::vector<CaseResult> run_all(const Options& options);

}  // namespace haustra::validation
