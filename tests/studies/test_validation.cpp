// The reference cases of `haustra validate`, asserted. Each case compares one number with an
// independent reference (closed form, or the elastica by shooting) under its stated tolerance.
#include <doctest/doctest.h>

#include "haustra/studies/validation.hpp"

using namespace haustra;
using namespace haustra::validation;

namespace {

void require_all(const std::vector<CaseResult>& results) {
  REQUIRE_FALSE(results.empty());
  for (const CaseResult& r : results) {
    INFO(r.name << " | " << r.quantity << " | reference " << r.reference << " value " << r.value << " error " << r.error
                << " tolerance " << r.tolerance << " | " << r.note);
    CHECK(r.pass);
    CHECK(r.error <= r.tolerance);
  }
}

}  // namespace

TEST_CASE("validate: axial end force gives eps = F/EA [newton]") { require_all(axial_end_force(SolverMode::newton)); }

TEST_CASE("validate: pure end moment gives an exact circle at N = 4 and 500, beyond a full turn") {
  require_all(pure_end_moment(SolverMode::newton));
  require_all(pure_end_moment(SolverMode::lagged));
}

TEST_CASE("validate: end torque gives tau = torque/T") {
  require_all(end_torque(SolverMode::newton));
  require_all(end_torque(SolverMode::lagged));
}

TEST_CASE("validate: cantilever under a small tip load, PL^3/3B within 1%") {
  require_all(cantilever_small_load(SolverMode::newton));
  require_all(cantilever_small_load(SolverMode::lagged));
}

TEST_CASE("validate: cantilever under large tip loads against the elastica within 1e-4") {
  require_all(cantilever_large_load(SolverMode::newton));
  require_all(cantilever_large_load(SolverMode::lagged));
}

TEST_CASE("validate: the cantilever error falls at second order as N doubles") {
  require_all(cantilever_convergence(SolverMode::newton));
}

TEST_CASE("validate: viscous rod under a constant moment, curvature grows at M/eta") {
  require_all(viscous_constant_moment(SolverMode::newton));
  require_all(viscous_constant_moment(SolverMode::lagged));
}

TEST_CASE("validate: elastic rod held at both ends sags as the beam quartic") {
  require_all(held_both_ends_elastic(SolverMode::newton));
  require_all(held_both_ends_elastic(SolverMode::lagged));
}

TEST_CASE("validate: viscous rod held at both ends settles on the catenary") {
  require_all(held_both_ends_viscous(SolverMode::newton));
}

TEST_CASE("validate: the unloaded rod reproduces the A-DSJ centreline") {
  require_all(centreline_rest_shape({}, SolverMode::newton));
}

TEST_CASE("validate: a reference case can fail") {
  // The comparison every case goes through: a value off by more than the tolerance fails, one
  // within it passes, relative and absolute alike.
  const CaseResult off = compare("case", "q", 2.0, 2.0 * (1.0 + 2e-6), 1e-6);
  CHECK_FALSE(off.pass);
  CHECK(off.error == doctest::Approx(2e-6).epsilon(1e-9));
  const CaseResult near = compare("case", "q", 2.0, 2.0 * (1.0 + 0.5e-6), 1e-6);
  CHECK(near.pass);
  const CaseResult negative = compare("case", "q", -2.0, -2.0 * (1.0 + 2e-6), 1e-6);
  CHECK_FALSE(negative.pass);
  CHECK_FALSE(compare_absolute("case", "q", 0.0, 3e-10, 1e-10).pass);
  CHECK(compare_absolute("case", "q", 0.0, -0.5e-10, 1e-10).pass);
  CHECK(compare_absolute("case", "q", 0.0, -0.5e-10, 1e-10).absolute);
}
