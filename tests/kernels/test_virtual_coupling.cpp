// The virtual coupling's capped spring against finite differences of its own energy, and its bound.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "haustra/kernels/virtual_coupling.hpp"

using haustra::kernels::virtual_coupling;

TEST_CASE(
    "virtual coupling: the force is minus the energy's gradient, the stiffness the force's, never above the limit") {
  const Eigen::Vector3d target(0.01, -0.02, 0.03);
  const double k = 1000.0, limit = 8.0;  // d0 = 8 mm
  const double h = 1e-7;
  double worst_force = 0.0, worst_stiffness = 0.0, largest = 0.0;
  // Stretches on both sides of d0 = 8 mm, in several directions.
  for (const double d : {0.001, 0.005, 0.0079, 0.0081, 0.02, 0.3}) {
    for (const Eigen::Vector3d& dir :
         std::array<Eigen::Vector3d, 3>{Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0.3, -0.4, 0.866).normalized(),
                                        Eigen::Vector3d(Eigen::Vector3d(-1, 2, 2) / 3.0)}) {
      const Eigen::Vector3d x = target + d * dir;
      const auto r = virtual_coupling(x, target, k, limit);
      largest = std::max(largest, r.force.norm() / limit);
      for (int i = 0; i < 3; ++i) {
        Eigen::Vector3d step = Eigen::Vector3d::Zero();
        step[i] = h;
        const auto plus = virtual_coupling(x + step, target, k, limit);
        const auto minus = virtual_coupling(x - step, target, k, limit);
        worst_force = std::max(worst_force, std::abs(-(plus.energy - minus.energy) / (2 * h) - r.force[i]) / limit);
        const Eigen::Vector3d column = -(plus.force - minus.force) / (2 * h);
        worst_stiffness = std::max(worst_stiffness, (column - r.stiffness.col(i)).norm() / k);
      }
      // Positive semi-definite: the frame's potential stays convex in it.
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(r.stiffness);
      CHECK(eig.eigenvalues().minCoeff() >= -1e-12 * k);
    }
  }
  MESSAGE("largest force / limit " << largest << ", force error " << worst_force << ", stiffness error "
                                   << worst_stiffness);
  CHECK(largest <= 1.0 + 1e-15);
  // Central differences of h = 1e-7 m: errors of order h² times the third derivative, and rounding
  // of energies of order 1 J over 2h. Measured: 1.1e-8 and 2.7e-9 of the limit and of k.
  CHECK(worst_force < 1e-7);
  CHECK(worst_stiffness < 3e-8);
}

TEST_CASE("virtual coupling: continuous at the limit, and a plain spring below it") {
  const Eigen::Vector3d target = Eigen::Vector3d::Zero();
  const double k = 500.0, limit = 4.0, d0 = limit / k;
  const auto below = virtual_coupling(Eigen::Vector3d(d0 * (1 - 1e-12), 0, 0), target, k, limit);
  const auto above = virtual_coupling(Eigen::Vector3d(d0 * (1 + 1e-12), 0, 0), target, k, limit);
  CHECK(std::abs(below.force.x() - above.force.x()) < 1e-10);
  CHECK(std::abs(below.energy - above.energy) < 1e-12);
  const auto spring = virtual_coupling(Eigen::Vector3d(0.001, 0.002, 0), target, k, limit);
  CHECK((spring.force - Eigen::Vector3d(-0.5, -1.0, 0)).norm() < 1e-15);
  CHECK(spring.energy == doctest::Approx(0.5 * k * 5e-6).epsilon(1e-14));
  CHECK(spring.unsaturated == doctest::Approx(k * std::sqrt(5e-6)).epsilon(1e-14));
}
