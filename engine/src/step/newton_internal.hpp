#pragma once
// What the Newton stages (newton_stages.cpp) and the line search (line_search.cpp) share: the
// coupled unknowns of a rod's solve, its parts, the trust region, and a whole re-solve.
#include <Eigen/Dense>
#include <span>

#include "step/collision.hpp"
#include "step/rod_stages.hpp"

namespace haustra::detail::newton {

constexpr int kMaxCoupled = static_cast<int>(kMaxConstraintRows + kMaxCoupledContacts);
using MatrixC = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxCoupled, kMaxCoupled>;
using VectorC = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxCoupled, 1>;

// A coupled contact pair: two beads of the segment, solved as one unknown force.
struct Pair {
  std::size_t a = 0, b = 0;                      // local nodes
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();  // separating direction, towards a
  double stiffness = 0.0;
};

// The unknowns a rod's Newton system couples beyond its sweep: attachment rows and contact pairs.
struct Coupled {
  ConstraintRows rows{};
  std::size_t m = 0;  // constraint rows
  std::array<Pair, kMaxCoupledContacts> pairs{};
  std::size_t pc = 0;  // coupled pairs
  [[nodiscard]] int columns() const { return 1 + static_cast<int>(m + pc); }
};

Coupled coupled_unknowns(const WorldModel& model, const WorldState& state, std::size_t rod);

// The parts a rod's solve runs in (model.solve_parts: one, or a split rod's tip and base parts).
std::span<const SolvePart> parts_of(const WorldModel& model, std::size_t rod);

// The largest fraction of the step the trust region allows.
double trust_scale(const SegmentModel& seg, const SegmentViews& v, const NewtonWorkspace& ws);

// The whole solve of one rod at a law scale, its parts one after another (the line search's
// stiffened re-solves): what the condense and solve stages do over all rods at once. False: no
// solve (a singular pivot without a banded fallback).
bool resolve(const WorldModel& model, WorldState& state, std::size_t rod, const SubstepParameters& p, double law_scale);

}  // namespace haustra::detail::newton
