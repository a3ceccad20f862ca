// Run-time parameters set between frames without a rebuild (gravity, dt, a grasp's coupling), the
// host's load on a node, and readings derived on request (velocities, section stresses).
#include <fmt/format.h>

#include <algorithm>
#include <vector>

#include "haustra/error.hpp"
#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/tissue_law.hpp"
#include "haustra/world.hpp"
#include "model/world_desc_checks.hpp"
#include "step/segment_law.hpp"
#include "step/world_impl.hpp"

namespace haustra {
namespace {

void check_span(std::span<double> out, std::size_t nodes, const char* what) {
  if (out.size() != 3 * nodes)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: expected room for 3 × {} nodes = {} values, got {}", what,
                                                         nodes, 3 * nodes, out.size()));
}

}  // namespace

void World::set_gravity(const Eigen::Vector3d& gravity) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  WorldDesc next = impl_->desc;
  next.gravity = gravity;
  detail::check_world_desc(next);
  impl_->desc.gravity = impl_->model.gravity = gravity;
}

// Everything that depends on dt reads it per frame (the substep length, the law's rate terms, the
// filter, the instruments' clock); fast mode refactorizes when the dt it recorded differs.
void World::set_dt(double dt) {
  const Use use(*this);
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  WorldDesc next = impl_->desc;
  next.dt = dt;
  detail::check_world_desc(next);
  impl_->desc.dt = impl_->model.dt = dt;
}

void World::set_instrument_coupling(std::size_t instrument, double stiffness, double damping, double force_limit) {
  const Use use(*this);
  impl_->check_instrument(instrument);
  InstrumentDesc next = impl_->desc.instruments[instrument];
  next.coupling_stiffness = stiffness;
  next.coupling_damping = damping;
  next.force_limit = force_limit;
  detail::check_instrument(next, instrument);
  const bool was_rigid = impl_->desc.instruments[instrument].coupling_stiffness == 0.0;
  if (was_rigid != (stiffness == 0.0))
    throw FieldError(ErrorCode::invalid_argument, fmt::format("instrument[{}].coupling_stiffness", instrument),
                     fmt::format("a grasp switches between rigid (0) and coupled (> 0) only through a rebuild "
                                 "(reconfigure); it is {} now",
                                 was_rigid ? "rigid" : "coupled"));
  InstrumentDesc& d = impl_->desc.instruments[instrument];
  detail::InstrumentModel& m = impl_->model.instruments[instrument];
  d.coupling_stiffness = m.coupling_stiffness = stiffness;
  d.coupling_damping = m.coupling_damping = damping;
  d.force_limit = m.force_limit = force_limit;
}

// The robust mode reads its limits per frame (frame.cpp); a rung above the new top comes down to it.
void World::set_frame_limits(const FrameLimits& limits) {
  const Use use(*this);
  WorldDesc next = impl_->desc;
  next.solver.max_substeps = limits.max_substeps;
  next.solver.max_retries = limits.max_retries;
  next.solver.calm_frames = limits.calm_frames;
  detail::check_world_desc(next);
  SolverDesc& d = impl_->desc.solver;
  detail::SolverModel& m = impl_->model.solver;
  d.max_substeps = m.max_substeps = limits.max_substeps;
  d.max_retries = m.max_retries = limits.max_retries;
  d.calm_frames = m.calm_frames = limits.calm_frames;
  impl_->state.robust_substeps = std::min(impl_->state.robust_substeps, limits.max_substeps);
}

FrameLimits World::frame_limits() const {
  const detail::SolverModel& s = impl_->model.solver;
  return {s.max_substeps, s.max_retries, s.calm_frames};
}

Eigen::Vector3d World::gravity() const { return impl_->model.gravity; }

std::pair<Eigen::Vector3d, Eigen::Vector3d> World::external_load(std::size_t node) const {
  impl_->check_node(node);
  return {impl_->state.external_force.view().get(node), impl_->state.external_moment.view().get(node)};
}

void World::node_velocities(std::span<double> linear, std::span<double> angular) const {
  const std::size_t n = impl_->model.node_total;
  check_span(linear, n, "node_velocities: linear");
  check_span(angular, n, "node_velocities: angular");
  const double dt = impl_->motion_dt;
  const auto& now = impl_->state.now;
  const auto& start = impl_->state.frame_start;
  for (std::size_t k = 0; k < n; ++k) {
    Eigen::Vector3d v = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
    if (dt > 0.0) {
      v = (now.position.view().get(k) - start.position.view().get(k)) / dt;
      const Eigen::Quaterniond turn = now.rotation.view().get(k) * start.rotation.view().get(k).conjugate();
      w = kernels::rotation_log(turn.normalized()) / dt;
    }
    for (std::size_t c = 0; c < 3; ++c) {
      linear[3 * k + c] = v[static_cast<Eigen::Index>(c)];
      angular[3 * k + c] = w[static_cast<Eigen::Index>(c)];
    }
  }
}

// The law's stress at the current strains with its rate over the last frame (the strains the frame
// started from, and its dt): elastic and viscous parts, as the frame's solve balanced them. Before
// the first frame (or after a pose or a restore) there is no rate: the elastic part alone.
void World::section_stresses(std::span<double> moments, std::span<double> forces) const {
  const std::size_t total = impl_->model.node_total;
  check_span(moments, total, "section_stresses: moments");
  check_span(forces, total, "section_stresses: forces");
  const auto& model = impl_->model;
  const std::vector<double>& strain = impl_->state.now.strain;
  const bool moved = impl_->motion_dt > 0.0;
  const std::vector<double>& start = moved ? impl_->state.frame_start.strain : strain;
  const double dt = moved ? impl_->motion_dt : model.dt;
  std::vector<double> stress(strain.size()), tangent(strain.size()), coupling(total);
  for (const detail::SegmentModel& seg : model.segments) {
    const std::size_t off = seg.node_offset, n = seg.node_count;
    auto part = [&](const std::vector<double>& v) {
      return kernels::StrainView<const double>{std::span<const double>(v).subspan(4 * off, 4 * n)};
    };
    const kernels::StrainView<double> s{std::span<double>(stress).subspan(4 * off, 4 * n)};
    if (seg.exp2) {
      kernels::nodal_law_evaluate(part(strain), part(model.rest_strain), part(start), detail::nodal_law_of(seg, dt), s,
                                  kernels::StrainView<double>{std::span<double>(tangent).subspan(4 * off, 4 * n)},
                                  std::span<double>(coupling).subspan(off, n));
    } else {
      const kernels::StrainLawCoefficients law = detail::law_of(seg, dt);
      const auto q = part(strain), rest = part(model.rest_strain), q0 = part(start);
      for (std::size_t k = 0; k < n; ++k)
        for (std::size_t c = 0; c < 4; ++c)
          s.at(k, c) = law.stiffness[c] * (q.at(k, c) - rest.at(k, c)) + law.rate[c] * (q.at(k, c) - q0.at(k, c));
    }
  }
  for (std::size_t k = 0; k < total; ++k) {
    for (std::size_t c = 0; c < 3; ++c) moments[3 * k + c] = stress[4 * k + c];
    forces[3 * k + 0] = forces[3 * k + 1] = 0.0;
    forces[3 * k + 2] = stress[4 * k + 3];
  }
}

}  // namespace haustra
