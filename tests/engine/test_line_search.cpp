// Newton's steps lower the frame's incremental potential (decision 0036): a large load applied at
// once reaches the elastica within one frame in a bounded number of iterations, and every iterate
// on the way has a lower potential than the one before.
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/references.hpp"
#include "haustra/world.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

namespace {

// scenes/cantilever.toml (1 m, 101 nodes, elastic, no gravity) with its tip load raised to PL²/B.
SceneDesc cantilever(double load_parameter) {
  SceneDesc sc = test::scene_desc("cantilever");
  sc.world.segments[0].loads[0].force *= load_parameter / 3.0;  // the scene's load is PL²/B = 3
  return sc;
}

double tip_error(const World& w, double load_parameter) {
  const auto pos = w.node_positions();
  const std::size_t tip = pos.x.size() - 1;
  const auto ref = reference::elastica_cantilever_tip(load_parameter);
  return std::hypot(pos.x[tip] - ref.x, pos.z[tip] - ref.z);
}

// The potential of an elastic rod under a dead tip load P: U − P·r_tip.
double potential(const World& w, const Eigen::Vector3d& load) {
  const auto pos = w.node_positions();
  const std::size_t tip = pos.x.size() - 1;
  return w.energy().elastic - load.dot(Eigen::Vector3d(pos.x[tip], pos.y[tip], pos.z[tip]));
}

}  // namespace

TEST_CASE("a large tip load applied at once reaches the elastica within one frame") {
  // Measured: 6 iterations to a strain change below 1e-12 for PL²/B = 3, 10 and 30; the tip within
  // 2.5e-5, 3.9e-5 and 6.2e-5 m of the elastica (the discretization's error at N = 100).
  for (const double load : {3.0, 10.0, 30.0}) {
    SceneDesc sc = cantilever(load);
    // Up to 100 iterations: the tolerance decides when to stop.
    sc.world.solver.iterations = 100;
    sc.world.solver.max_iterations = 100;
    sc.world.solver.tolerance = 1e-12;
    auto w = create_world(sc);
    w->step();
    CAPTURE(load);
    CHECK(w->last_profile().iterations <= 8);
    CHECK(w->last_profile().substeps == 1);
    CHECK(w->events().empty());
    CHECK(tip_error(*w, load) < 1e-4);
  }
}

TEST_CASE("every Newton iterate under a large load lowers the potential, and the iterates reach the elastica") {
  // One iteration per frame: an elastic rod's quasi-static frames are iterates of one potential.
  // Before the line search, PL²/B = 10 wandered for 30–200 frames with the tip above the clamp at
  // frames 1 and 30; measured now: 3 frames to the elastica (error 3.9e-5 m), each lower.
  for (const double load : {10.0, 30.0}) {
    SceneDesc sc = cantilever(load);
    sc.world.solver.iterations = 1;
    sc.world.solver.max_iterations = 1;
    const Eigen::Vector3d p = sc.world.segments[0].loads[0].force;
    auto w = create_world(sc);
    double before = potential(*w, p);
    int frames_to_converge = -1;
    for (int f = 0; f < 12; ++f) {
      w->step();
      const double now = potential(*w, p);
      CAPTURE(load);
      CAPTURE(f);
      // Rounding: the potential is ~PL (1e-5 J); the backward sweep's generalized forces are its
      // gradient to O(h²), which the line search allows for at 1e-10 of its terms.
      CHECK(now <= before + 1e-15);
      const auto pos = w->node_positions();
      CHECK(pos.z.back() < 0.0);  // never above the clamp
      if (frames_to_converge < 0 && tip_error(*w, load) < 1e-4) frames_to_converge = f + 1;
      before = now;
    }
    MESSAGE("PL²/B = " << load << ": " << frames_to_converge << " one-iteration frames to the elastica");
    CHECK(frames_to_converge > 0);
    CHECK(frames_to_converge <= 6);
    CHECK(w->events().empty());
  }
}

TEST_CASE("a load no step can carry is reported, never taken as a converged frame") {
  // scenes/cantilever.toml with 6 kN and 20 kN at its tip (the silent stall: every frame
  // returned OK, the rod never moved). Measured: at frame 0 the refused Newton step would turn a
  // section by 14.9 rad and stretch a node by 2.05, far past the stall threshold of 0.05; every rung
  // of the robust mode stalls the same way, so the frame stops with the cause.
  for (const double newtons : {6e3, 2e4}) {
    SceneDesc sc = test::scene_desc("cantilever");
    sc.world.segments[0].loads[0].force = Eigen::Vector3d(0.0, 0.0, -newtons);
    auto w = create_world(sc);
    CAPTURE(newtons);
    std::string message;
    try {
      w->step();
    } catch (const Error& e) {
      CHECK(e.code() == ErrorCode::unstable);
      message = e.what();
    }
    CHECK(message.find("no progress") != std::string::npos);
    CHECK(message.find("line_search") != std::string::npos);
    CHECK(w->frame() == 0);  // the last good frame kept
    CHECK(w->last_profile().stalls >= 1);
    REQUIRE(!w->events().empty());
    CHECK(w->events().back().kind == Event::Kind::unstable);
  }
  // The scene's own load (PL²/B = 3) is carried: no stall, no event.
  auto w = create_world(test::scene_desc("cantilever"));
  for (int f = 0; f < 5; ++f) w->step();
  CHECK(w->events().empty());
  CHECK(w->last_profile().stalls == 0);
}
