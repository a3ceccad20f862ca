// Connective tissue's anchor against finite differences of its own energy, and its closed forms.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "haustra/kernels/tissue_anchor.hpp"

using haustra::kernels::tissue_anchor;
using haustra::kernels::tissue_anchor_tension;

TEST_CASE("tissue anchor: the force is minus the energy's gradient, the stiffness the force's, both PSD") {
  const Eigen::Vector3d target(0.01, -0.02, 0.03), start(0.012, -0.018, 0.031);
  const double k = 25.0, rate = 15.0, support = 40.0;  // 5 mm of organ at 5 kN/m², 50 N·s/m², Δt = 1/60 s
  const Eigen::Vector3d down = Eigen::Vector3d(0.2, -0.3, -1.0).normalized();
  const double h = 1e-7;
  double worst_force = 0.0, worst_stiffness = 0.0;
  for (const double slack : {0.0, 0.004}) {
    for (const double d : {0.001, 0.0039, 0.0041, 0.02, 0.3}) {
      for (const Eigen::Vector3d& dir :
           std::array<Eigen::Vector3d, 3>{Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0.3, -0.4, 0.866).normalized(),
                                          Eigen::Vector3d(Eigen::Vector3d(-1, 2, 2) / 3.0)}) {
        const Eigen::Vector3d x = target + d * dir;
        const auto r = tissue_anchor(x, start, target, k, slack, rate, support, down);
        for (int i = 0; i < 3; ++i) {
          Eigen::Vector3d step = Eigen::Vector3d::Zero();
          step[i] = h;
          const auto plus = tissue_anchor(x + step, start, target, k, slack, rate, support, down);
          const auto minus = tissue_anchor(x - step, start, target, k, slack, rate, support, down);
          const double scale = (k + support) * d + rate * (x - start).norm() + 1e-3;
          worst_force = std::max(worst_force, std::abs(-(plus.energy - minus.energy) / (2 * h) - r.force[i]) / scale);
          const Eigen::Vector3d column = -(plus.force - minus.force) / (2 * h);
          // Where a step crosses the slack or the support's level the stiffness jumps (only the
          // gradient is continuous).
          if (std::abs(d - slack) > 2 * h && std::abs((x - target).dot(down)) > 2 * h)
            worst_stiffness = std::max(worst_stiffness, (column - r.stiffness.col(i)).norm() / (k + rate + support));
        }
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(r.stiffness);
        CHECK(eig.eigenvalues().minCoeff() >= -1e-12 * (k + rate + support));
        CHECK(r.tension == doctest::Approx(tissue_anchor_tension(x, target, k, slack)).epsilon(1e-14));
      }
    }
  }
  MESSAGE("force error " << worst_force << ", stiffness error " << worst_stiffness << " (relative)");
  // Central differences of 1e-7 m: rounding of energies over 2h. Measured: 9.5e-11 and 3.0e-10.
  CHECK(worst_force < 1e-9);
  CHECK(worst_stiffness < 3e-9);
}

TEST_CASE("tissue anchor: free within its slack, a spring of k beyond it, the damper on the node's own motion") {
  const Eigen::Vector3d target = Eigen::Vector3d::Zero(), at_rest = Eigen::Vector3d(0.005, 0, 0);
  const double k = 40.0, slack = 0.01;
  const auto slackened = tissue_anchor(at_rest, at_rest, target, k, slack, 100.0);
  CHECK(slackened.force.norm() == 0.0);
  CHECK(slackened.energy == 0.0);
  CHECK(slackened.tension == 0.0);
  // 3 cm out with 1 cm of slack: 2 cm of stretch.
  const Eigen::Vector3d x(0.0, 0.03, 0.0);
  const auto taut = tissue_anchor(x, x, target, k, slack, 100.0);
  CHECK((taut.force - Eigen::Vector3d(0, -0.8, 0)).norm() < 1e-15);
  CHECK(taut.tension == doctest::Approx(0.8).epsilon(1e-14));
  CHECK(taut.energy == doctest::Approx(0.5 * k * 4e-4).epsilon(1e-14));
  // Across the anchor: the tension over its length, 0.8 / 0.03.
  CHECK(taut.stiffness(0, 0) == doctest::Approx(100.0 + 0.8 / 0.03).epsilon(1e-14));
  CHECK(taut.stiffness(1, 1) == doctest::Approx(100.0 + k).epsilon(1e-14));
  // The damper: c/Δt times the motion since the substep's start.
  const auto damped = tissue_anchor(at_rest, Eigen::Vector3d(0.004, 0, 0), target, k, slack, 100.0);
  CHECK((damped.force - Eigen::Vector3d(-0.1, 0, 0)).norm() < 1e-15);
  // The support: only against sinking along `down`, k_s (d·down) there, nothing above.
  const Eigen::Vector3d down(0, 0, -1);
  const auto sunk = tissue_anchor(Eigen::Vector3d(0.01, 0, -0.002), Eigen::Vector3d(0.01, 0, -0.002), target, 0.0, 0.0,
                                  0.0, 500.0, down);
  CHECK((sunk.force - Eigen::Vector3d(0, 0, 1.0)).norm() < 1e-15);
  CHECK(sunk.stiffness(2, 2) == 500.0);
  CHECK(sunk.stiffness(0, 0) == 0.0);
  const auto lifted =
      tissue_anchor(Eigen::Vector3d(0, 0, 0.05), Eigen::Vector3d(0, 0, 0.05), target, 0.0, 0.0, 0.0, 500.0, down);
  CHECK(lifted.force.norm() == 0.0);
  CHECK(lifted.energy == 0.0);
  // No slack: linear, k I everywhere (the target itself included).
  const auto plain = tissue_anchor(target, target, target, k, 0.0, 0.0);
  CHECK((plain.stiffness - k * Eigen::Matrix3d::Identity()).norm() == 0.0);
}

TEST_CASE("tissue anchor's turn: a torsion spring towards the rest frame and a damper on the turn, in world axes") {
  const Eigen::Quaterniond rest(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Vector3d axis = Eigen::Vector3d(-1, 0.5, 0.2).normalized();
  const Eigen::Quaterniond turned = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, axis)) * rest;
  const auto t = haustra::kernels::tissue_anchor_turn(turned, turned, rest, 2.0, 7.0);
  CHECK((t.moment + 2.0 * 0.3 * axis).norm() < 1e-14);
  CHECK(t.energy == doctest::Approx(0.5 * 2.0 * 0.09).epsilon(1e-13));
  CHECK(t.stiffness == 9.0);
  // Turned by 0.1 rad about x over the substep, at rest otherwise: the damper alone.
  const Eigen::Quaterniond start = Eigen::Quaterniond(Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitX())) * rest;
  const auto d = haustra::kernels::tissue_anchor_turn(rest, start, rest, 2.0, 7.0);
  CHECK((d.moment + 0.7 * Eigen::Vector3d::UnitX()).norm() < 1e-14);
}
