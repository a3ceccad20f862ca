// Fast mode (decision 0037): Newton reusing its factorization while the rod's contacts and grasps
// stand. It must reach what Newton reaches, reuse factorizations where nothing changed, and factor
// afresh where something did.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "haustra/profile.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/references.hpp"
#include "haustra/world.hpp"
#include "scene_fixtures.hpp"

using namespace haustra;

namespace {

double largest_distance(const World& a, const World& b) {
  const auto pa = a.node_positions(), pb = b.node_positions();
  double worst = 0.0;
  for (std::size_t k = 0; k < pa.x.size(); ++k)
    worst = std::max(worst, std::hypot(pa.x[k] - pb.x[k], pa.y[k] - pb.y[k], pa.z[k] - pb.z[k]));
  return worst;
}

}  // namespace

TEST_CASE("fast mode reaches the elastica under a large load applied at once, reusing its factorization") {
  // scenes/cantilever.toml: PL²/B = 3 from straight. One chord iteration a frame converges
  // linearly; measured: within 1e-4 m of the elastica from frame 11 (the discretization's error is
  // 2.5e-5), 8 of the first 15 frames reused a factorization.
  SceneDesc s = test::scene_desc("cantilever", {"solver.mode=fast"});
  auto w = create_world(s);
  const auto ref = reference::elastica_cantilever_tip(3.0);
  int chords = 0;
  for (int f = 0; f < 15; ++f) {
    w->step();
    chords += w->last_profile().chords;
  }
  const auto p = w->node_positions();
  const std::size_t tip = p.x.size() - 1;
  CHECK(std::hypot(p.x[tip] - ref.x, p.z[tip] - ref.z) < 1e-4);
  CHECK(chords >= 5);
  CHECK(w->events().empty());
  // Settled, frames reuse it until it is kRefactorFrames (8) old.
  int settled = 0;
  for (int f = 0; f < 16; ++f) {
    w->step();
    settled += w->last_profile().chords;
  }
  CHECK(settled == 14);
}

TEST_CASE("fast mode on drop: the fall as converged Newton's, factorizations reused, fresh ones where contacts begin") {
  // Measured: at frame 10 (falling, nothing touches yet) within 1e-12 m of Newton iterated to
  // convergence; over 150 frames about two thirds of the iterations reuse a factorization, and a
  // bead that starts touching forces a new one.
  SceneDesc fast = test::scene_desc("drop", {"solver.mode=fast"});
  SceneDesc exact = test::scene_desc("drop", {"solver.iterations=40", "solver.tolerance=1e-10"});
  auto a = create_world(fast);
  auto b = create_world(exact);
  for (int f = 0; f < 10; ++f) {
    a->step();
    b->step();
  }
  const double before_contact = largest_distance(*a, *b);
  int iterations = 0, chords = 0;
  std::size_t most_touching = 0;
  double after_contact = 0.0;  // the largest gap to converged Newton once beads touch
  double centroid_gap = 0.0;   // the rod's centre of mass against converged Newton's, once touching
  int first_touch_a = -1, first_touch_b = -1;
  auto centroid = [](const World& w) {
    const auto p = w.node_positions();
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < w.node_count(); ++k) c += p.get(k);
    return Eigen::Vector3d(c / static_cast<double>(w.node_count()));
  };
  for (int f = 10; f < 150; ++f) {
    a->step();
    b->step();
    iterations += a->last_profile().iterations;
    chords += a->last_profile().chords;
    most_touching = std::max(most_touching, a->contacts().touching);
    if (first_touch_a < 0 && a->contacts().touching > 0) first_touch_a = f;
    if (first_touch_b < 0 && b->contacts().touching > 0) first_touch_b = f;
    if (a->contacts().touching > 0) {
      after_contact = std::max(after_contact, largest_distance(*a, *b));
      centroid_gap = std::max(centroid_gap, (centroid(*a) - centroid(*b)).norm());
    }
  }

  MESSAGE("drop in fast mode, frames 10–150: "
          << chords << " of " << iterations << " iterations reused a factorization; from converged Newton "
          << before_contact << " m at frame 10, up to " << after_contact
          << " m at a node once touching, the centre of mass within " << centroid_gap << " m; first touch at frames "
          << first_touch_a << " and " << first_touch_b);
  CHECK(before_contact < 5e-12);  // measured 5.3e-13 m: one iteration a frame, converged while falling
  // Once beads touch, a pile-up is chaotic: a micrometre at the first touch grows to centimetres at
  // a node (measured 77 mm), so the comparison is of what the pile does as a whole — the centre of
  // mass (measured within 11.8 mm) and when it lands (frames 17 and 15).
  CHECK(centroid_gap < 0.1);
  CHECK(std::abs(first_touch_a - first_touch_b) <= 3);
  CHECK(most_touching > 10);       // it landed and piled up
  CHECK(chords > iterations / 2);  // mostly reused
  CHECK(chords < iterations);      // and factored afresh where contacts began
  CHECK(a->contacts().max_environment_depth_ratio < 0.2);
  CHECK(a->contacts().max_bead_overlap_ratio < 0.3);
}

TEST_CASE(
    "fast mode keeps a long rod whole and reuses its factorization (decision 0062), the same bits with 1 and 2 "
    "threads") {
  // The bowel: one chained rod of 641 nodes, which Newton solves in two parts (decision 0040). Split,
  // fast mode had no record to replay and refactored every frame (0 chords).
  auto run = [](int threads) {
    auto w = test::scene_world("bowel", threads, {"solver.mode=fast"});
    int chords = 0, iterations = 0;
    for (int f = 0; f < 40; ++f) {
      w->step();
      chords += w->last_profile().chords;
      iterations += w->last_profile().iterations;
    }
    MESSAGE(threads << " threads: " << chords << " chords in " << iterations << " iterations");
    CHECK(chords >= 10);  // 44 of 101 iterations in release, 27 of 118 under ASan's code generation
    return test::positions(*w);
  };
  const std::vector<double> one = run(1);
  CHECK(run(2) == one);
}
