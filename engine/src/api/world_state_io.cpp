// Writing a world's state from arrays (decision 0102): strains, node poses or positions, many nodes'
// loads at once, loads per length. Every setter checks all it is given before it writes anything,
// so a refused call leaves the world as it was.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <Eigen/QR>

#include "haustra/kernels/rod_forward_sweep.hpp"
#include "model/field_checks.hpp"
#include "step/world_impl.hpp"

namespace haustra {
namespace {

[[noreturn]] void refuse(const std::string& what) { throw Error(ErrorCode::invalid_argument, what); }

// The rod's node strains from its sections' (ξ_k = ½(q_k + q_{k+1}), k < n − 1): one free value per
// component, taken so that the nodes lie closest to `target` (least squares): q_k = a_k + (−1)^k s.
void split_section_strains(std::span<const double> section, std::span<const double> target, std::span<double> out) {
  const std::size_t n = target.size() / 4;
  for (std::size_t c = 0; c < 4; ++c) {
    out[c] = target[c];
    for (std::size_t k = 0; k + 1 < n; ++k) out[4 * (k + 1) + c] = 2.0 * section[4 * k + c] - out[4 * k + c];
    double s = 0.0;
    for (std::size_t k = 0; k < n; ++k) s -= (k % 2 == 0 ? 1.0 : -1.0) * (out[4 * k + c] - target[4 * k + c]);
    s /= static_cast<double>(n);
    for (std::size_t k = 0; k < n; ++k) out[4 * k + c] += (k % 2 == 0 ? 1.0 : -1.0) * s;
  }
}

}  // namespace

void World::set_strains(std::span<const double> strains) {
  const Use use(*this);                  // one thread at a time (decision 0100)
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  auto& m = impl_->model;
  auto& st = impl_->state;
  if (strains.size() != 4 * m.node_total)
    refuse(fmt::format("set_strains: expected {} values (4 per node: κ1 κ2 τ ε, for {} nodes), got {}",
                       4 * m.node_total, m.node_total, strains.size()));
  for (std::size_t i = 0; i < strains.size(); ++i)
    if (!std::isfinite(strains[i]))
      refuse(fmt::format("set_strains: node {}'s strain {} is {}: expected finite numbers", i / 4, i % 4, strains[i]));
  for (std::size_t i = 3; i < strains.size(); i += 4)
    if (!(strains[i] > -1.0))
      refuse(
          fmt::format("set_strains: node {}'s axial strain ε = {}: a section cannot shrink to nothing (expected "
                      "ε > −1)",
                      i / 4, strains[i]));
  std::copy(strains.begin(), strains.end(), st.now.strain.begin());
  impl_->motion_dt = 0.0;
  for (std::size_t s = 0; s < m.segments.size(); ++s) {
    const detail::SegmentViews v = detail::segment_views(m, st, s);
    kernels::rod_forward_sweep(st.now.base[s], v.section_length, v.strain, v.poses);
  }
  st.frame_start.copy_from(st.now);
  impl_->follow_rod();
}

void World::set_node_poses(kernels::Vec3View<const double> positions, kernels::RotationView<const double> rotations,
                           double shear_tolerance) {
  const Use use(*this);                  // one thread at a time (decision 0100)
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  auto& m = impl_->model;
  auto& st = impl_->state;
  const std::size_t total = m.node_total;
  if (positions.size() != total || rotations.size() != total)
    refuse(fmt::format("set_node_poses: expected {} positions and {} rotations (one per node), got {} and {}", total,
                       total, positions.size(), rotations.size()));
  if (!(shear_tolerance >= 0.0) || !std::isfinite(shear_tolerance))
    refuse(fmt::format("set_node_poses: shear_tolerance = {}: expected a finite number >= 0", shear_tolerance));
  for (std::size_t k = 0; k < total; ++k) {
    const Eigen::Quaterniond q = rotations.get(k);
    if (!positions.get(k).allFinite() || !q.coeffs().allFinite())
      refuse(fmt::format("set_node_poses: node {}'s pose is not finite", k));
    if (positions.get(k).cwiseAbs().maxCoeff() > detail::kMaxVectorComponent)
      refuse(fmt::format("set_node_poses: node {}'s position is beyond ±{:g} m in a component", k,
                         detail::kMaxVectorComponent));
    if (std::abs(q.norm() - 1.0) > 1e-6)
      refuse(fmt::format("set_node_poses: node {}'s rotation has norm {}: expected a unit quaternion (w, x, y, z)", k,
                         q.norm()));
  }
  // Each section's strain from its nodes' relative pose: the rotation's logarithm over the section's
  // length gives (κ1, κ2, τ); the translation is then (1 + ε) times that of the unstretched section,
  // up to a shear the rod cannot take.
  std::vector<double> section(4 * total, 0.0), strains(4 * total, 0.0);
  for (std::size_t s = 0; s < m.segments.size(); ++s) {
    const detail::SegmentModel& seg = m.segments[s];
    const std::size_t o = seg.node_offset, n = seg.node_count;
    for (std::size_t k = 0; k + 1 < n; ++k) {
      const double h = m.section_length[o + k];
      const Eigen::Quaterniond qa = rotations.get(o + k).normalized(), qb = rotations.get(o + k + 1).normalized();
      const Eigen::Vector3d u = kernels::rotation_log(qa.conjugate() * qb) / h;
      const Eigen::Vector3d chord = qa.conjugate() * (positions.get(o + k + 1) - positions.get(o + k));
      const Eigen::Vector3d unit = kernels::section_exp(u, 0.0, h).position;
      const double stretch = chord.dot(unit) / unit.squaredNorm();
      const double shear = (chord - stretch * unit).norm();
      if (shear > shear_tolerance * h)
        refuse(
            fmt::format("set_node_poses: segment '{}', section {} (nodes {} and {}): the poses shear it by {:.3g} m "
                        "over its {:.3g} m (allowed: {:.3g} of its length): the rod is unshearable, so its node "
                        "positions and frames must come from one configuration (or write strains)",
                        seg.info.name, k, o + k, o + k + 1, shear, h, shear_tolerance));
      if (!(stretch > 0.0))
        refuse(
            fmt::format("set_node_poses: segment '{}', section {}: node {} lies behind node {} along its frame "
                        "(a section cannot turn back on itself)",
                        seg.info.name, k, o + k + 1, o + k));
      for (int c = 0; c < 3; ++c) section[4 * (o + k) + static_cast<std::size_t>(c)] = u[c];
      section[4 * (o + k) + 3] = stretch - 1.0;
    }
    split_section_strains(std::span<const double>(section).subspan(4 * o, 4 * n),
                          std::span<const double>(st.now.strain).subspan(4 * o, 4 * n),
                          std::span<double>(strains).subspan(4 * o, 4 * n));
  }
  for (std::size_t s = 0; s < m.segments.size(); ++s) {
    const std::size_t o = m.segments[s].node_offset;
    st.now.base[s] = {rotations.get(o).normalized(), positions.get(o)};
  }
  set_strains(strains);
}

void World::set_node_positions(kernels::Vec3View<const double> positions) {
  const Use use(*this);                  // one thread at a time (decision 0100)
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  auto& m = impl_->model;
  const std::size_t total = m.node_total;
  if (positions.size() != total)
    refuse(fmt::format("set_node_positions: expected {} positions (one per node), got {}", total, positions.size()));
  for (std::size_t k = 0; k < total; ++k)
    if (!positions.get(k).allFinite() || positions.get(k).cwiseAbs().maxCoeff() > detail::kMaxVectorComponent)
      refuse(fmt::format("set_node_positions: node {}'s position is not finite or beyond ±{:g} m in a component", k,
                         detail::kMaxVectorComponent));
  // Frames that turn least along the points (no twist): each section an arc from its start frame
  // through the next point, which fixes the next frame. The first frame's tangent is free: a wrong one
  // leaves a zig-zag of the sections' bends (θ_k + θ_{k+1} is what the points fix), so it is chosen to
  // make consecutive sections' bends (world frame) differ least — Gauss–Newton over its two angles, from
  // the tangent a circle through the first three points has.
  std::vector<double> w(total), x(total), y(total), z(total);
  const kernels::RotationView<double> frames{w, x, y, z};
  for (std::size_t s = 0; s < m.segments.size(); ++s) {
    const detail::SegmentModel& seg = m.segments[s];
    const std::size_t o = seg.node_offset, n = seg.node_count;
    std::vector<Eigen::Vector3d> chord(n - 1);
    for (std::size_t k = 0; k + 1 < n; ++k) {
      chord[k] = positions.get(o + k + 1) - positions.get(o + k);
      if (!(chord[k].norm() > 1e-9 * m.section_length[o + k]))
        refuse(fmt::format("set_node_positions: segment '{}': nodes {} and {} are at the same place", seg.info.name,
                           o + k, o + k + 1));
      chord[k].normalize();
    }
    Eigen::Vector3d tangent = chord[0];
    if (n > 2) {  // half the turn at node 1 back from the first chord
      const Eigen::Vector3d axis = chord[0].cross(chord[1]);
      const double angle = std::atan2(axis.norm(), chord[0].dot(chord[1]));
      if (axis.norm() > 1e-15) tangent = Eigen::AngleAxisd(-0.5 * angle, axis.normalized()) * chord[0];
    }
    const Eigen::Quaterniond now = impl_->state.now.base[s].rotation.normalized();
    const Eigen::Quaterniond guess =
        (Eigen::Quaterniond::FromTwoVectors(now * Eigen::Vector3d::UnitZ(), tangent) * now).normalized();
    // From a first frame: every node's frame (when `out`), each section's bend (world frame, per metre) into
    // `bends`, and the steepest turn of a section (rad).
    std::vector<Eigen::Vector3d> bends(n - 1);
    auto propagate = [&](const Eigen::Quaterniond& first, bool out) {
      Eigen::Quaterniond frame = first;
      if (out) frames.set(o, frame);
      double steepest = 0.0;
      for (std::size_t k = 0; k + 1 < n; ++k) {
        const Eigen::Vector3d c = frame.conjugate() * chord[k];
        const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ().cross(c);
        const double theta = std::atan2(axis.norm(), c.z());
        steepest = std::max(steepest, theta);
        const Eigen::Vector3d turn =
            axis.norm() > 1e-15 ? Eigen::Vector3d(2.0 * theta * axis.normalized()) : Eigen::Vector3d::Zero();
        bends[k] = frame * turn / m.section_length[o + k];
        frame = (frame * kernels::rotation_exp(turn)).normalized();
        if (out) frames.set(o + k + 1, frame);
      }
      return steepest;
    };
    auto residual = [&](const Eigen::Vector2d& a) {  // consecutive bends' differences, first frame tilted by a
      const Eigen::Vector3d e1 = guess * Eigen::Vector3d::UnitX(), e2 = guess * Eigen::Vector3d::UnitY();
      propagate((kernels::rotation_exp(a.x() * e1 + a.y() * e2) * guess).normalized(), false);
      Eigen::VectorXd r(3 * static_cast<Eigen::Index>(n > 2 ? n - 2 : 0));
      for (std::size_t k = 1; k + 1 < n; ++k)
        r.segment<3>(3 * static_cast<Eigen::Index>(k - 1)) = bends[k] - bends[k - 1];
      return r;
    };
    Eigen::Vector2d tilt = Eigen::Vector2d::Zero();
    for (int iteration = 0; iteration < 8 && n > 3; ++iteration) {
      const Eigen::VectorXd r = residual(tilt);
      Eigen::MatrixXd jacobian(r.size(), 2);
      for (int j = 0; j < 2; ++j) {
        Eigen::Vector2d moved = tilt;
        moved[j] += 1e-7;
        jacobian.col(j) = (residual(moved) - r) / 1e-7;
      }
      const Eigen::Vector2d step = jacobian.colPivHouseholderQr().solve(-r);
      if (!step.allFinite()) break;
      tilt += step;
      if (step.norm() < 1e-12) break;
    }
    const Eigen::Vector3d e1 = guess * Eigen::Vector3d::UnitX(), e2 = guess * Eigen::Vector3d::UnitY();
    const double steepest =
        propagate((kernels::rotation_exp(tilt.x() * e1 + tilt.y() * e2) * guess).normalized(), true);
    if (steepest > 0.25 * std::numbers::pi) {
      std::size_t k = 0;
      while (k + 1 < n && 0.5 * bends[k].norm() * m.section_length[o + k] <= 0.25 * std::numbers::pi) ++k;
      refuse(
          fmt::format("set_node_positions: segment '{}', section {} (nodes {} and {}): the points turn it by "
                      "{:.0f}° (more than 90° within one section): smooth the points or use more nodes",
                      seg.info.name, k, o + k, o + k + 1, 2.0 * steepest * 180.0 / std::numbers::pi));
    }
  }
  set_node_poses(positions, frames, 1e-6);
  // Points describe a shape, not a history: each node's strain is split from its sections' so that it
  // lies closest to their mean (smooth along the rod), not closest to what the node held before.
  std::vector<double> section(4 * total), smooth(4 * total), mean(4 * total);
  const std::vector<double>& q = impl_->state.now.strain;
  for (const detail::SegmentModel& seg : m.segments) {
    const std::size_t o = seg.node_offset, n = seg.node_count;
    for (std::size_t k = 0; k + 1 < n; ++k)
      for (std::size_t c = 0; c < 4; ++c)
        section[4 * (o + k) + c] = 0.5 * (q[4 * (o + k) + c] + q[4 * (o + k + 1) + c]);
    for (std::size_t k = 0; k < n; ++k)
      for (std::size_t c = 0; c < 4; ++c) {
        const double before = k > 0 ? section[4 * (o + k - 1) + c] : section[4 * (o + k) + c];
        const double after = k + 1 < n ? section[4 * (o + k) + c] : section[4 * (o + k - 1) + c];
        mean[4 * (o + k) + c] = 0.5 * (before + after);
      }
    split_section_strains(std::span<const double>(section).subspan(4 * o, 4 * n),
                          std::span<const double>(mean).subspan(4 * o, 4 * n),
                          std::span<double>(smooth).subspan(4 * o, 4 * n));
  }
  set_strains(smooth);
}

void World::set_base_pose(std::size_t segment, const kernels::Pose& base) {
  const Use use(*this);                  // one thread at a time (decision 0100)
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  const std::size_t rod = impl_->piece(segment).rod;
  const detail::SegmentModel& seg = impl_->model.segments[rod];
  const std::vector<double> strains(
      impl_->state.now.strain.begin() + static_cast<std::ptrdiff_t>(4 * seg.node_offset),
      impl_->state.now.strain.begin() + static_cast<std::ptrdiff_t>(4 * (seg.node_offset + seg.node_count)));
  pose_rod(seg.first_piece, base, strains);
}

void World::set_external_loads(std::span<const std::uint32_t> nodes, std::span<const double> forces,
                               std::span<const double> moments, bool add) {
  const Use use(*this);                  // one thread at a time (decision 0100)
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  auto& st = impl_->state;
  if (forces.size() != 3 * nodes.size() || (!moments.empty() && moments.size() != 3 * nodes.size()))
    refuse(
        fmt::format("set_external_loads: {} nodes need {} force values (3 each) and {} moment values or none; got "
                    "{} and {}",
                    nodes.size(), 3 * nodes.size(), 3 * nodes.size(), forces.size(), moments.size()));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    impl_->check_node(nodes[i]);
    for (std::size_t j = 0; j < 3; ++j)
      if (!(std::abs(forces[3 * i + j]) <= detail::kMaxVectorComponent) ||
          (!moments.empty() && !(std::abs(moments[3 * i + j]) <= detail::kMaxVectorComponent)))
        refuse(
            fmt::format("set_external_loads: the load on node {} (entry {}) is not finite or beyond ±{:g} N (N·m) "
                        "in a component: no step holds it",
                        nodes[i], i, detail::kMaxVectorComponent));
  }
  if (!add)  // replaced first, so a node listed twice gets the sum of its entries
    for (std::uint32_t node : nodes) {
      st.external_force.view().set(node, Eigen::Vector3d::Zero());
      st.external_moment.view().set(node, Eigen::Vector3d::Zero());
    }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Eigen::Vector3d f(forces[3 * i], forces[3 * i + 1], forces[3 * i + 2]);
    st.external_force.view().set(nodes[i], st.external_force.view().get(nodes[i]) + f);
    if (moments.empty()) continue;
    const Eigen::Vector3d mo(moments[3 * i], moments[3 * i + 1], moments[3 * i + 2]);
    st.external_moment.view().set(nodes[i], st.external_moment.view().get(nodes[i]) + mo);
  }
}

void World::set_distributed_load(std::size_t segment, std::span<const double> force_per_length,
                                 std::span<const double> moment_per_length, bool add) {
  const Use use(*this);                  // one thread at a time (decision 0100)
  const Impl::WakeOnChange wake(impl_);  // sleeping rods move again (decision 0119)
  const detail::SegmentPiece& piece = impl_->piece(segment);
  const std::size_t o = piece.info.nodes.offset, n = piece.info.nodes.count;
  if (force_per_length.size() != 3 * n || (!moment_per_length.empty() && moment_per_length.size() != 3 * n))
    refuse(
        fmt::format("set_distributed_load: segment '{}' has {} nodes: expected {} force values (N/m, 3 per node) "
                    "and {} moment values (N·m/m) or none; got {} and {}",
                    piece.info.name, n, 3 * n, 3 * n, force_per_length.size(), moment_per_length.size()));
  std::vector<std::uint32_t> nodes(n);
  std::vector<double> forces(3 * n), moments(moment_per_length.empty() ? 0 : 3 * n);
  const std::span<const double> h = impl_->model.section_length;
  for (std::size_t k = 0; k < n; ++k) {
    nodes[k] = static_cast<std::uint32_t>(o + k);
    // The node's share of the rod's rest length: half of each section beside it (in this segment).
    const double share = 0.5 * ((k > 0 ? h[o + k - 1] : 0.0) + (k + 1 < n ? h[o + k] : 0.0));
    for (std::size_t j = 0; j < 3; ++j) {
      forces[3 * k + j] = share * force_per_length[3 * k + j];
      if (!moments.empty()) moments[3 * k + j] = share * moment_per_length[3 * k + j];
    }
  }
  set_external_loads(nodes, forces, moments, add);
}

}  // namespace haustra
