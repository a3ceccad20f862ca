// One rod's Newton system of the implicit strain law: residual, Jacobian and their assembly.
#include "haustra/kernels/rod_newton.hpp"
#include "haustra/kernels/pose.hpp"

#include <Eigen/Geometry>
#include "haustra/kernels/mass_matrix.hpp"

namespace haustra::kernels {
namespace {

// Linearization of section k's generalized force:
// δs = P δφ_k + Q δM_k + Fm δF_k + X (δq_k + δq_{k+1}).
struct SectionLinearization {
  Eigen::Matrix<double, 4, 3> p = Eigen::Matrix<double, 4, 3>::Zero();  // per δφ_k
  Eigen::Matrix<double, 4, 3> q = Eigen::Matrix<double, 4, 3>::Zero();  // per δM_k
  Eigen::Matrix<double, 4, 3> f = Eigen::Matrix<double, 4, 3>::Zero();  // per δF_k
  Eigen::Matrix4d x = Eigen::Matrix4d::Zero();                          // per δq_k + δq_{k+1}
};

SectionLinearization linearize_section(const Eigen::Matrix3d& rm, const Eigen::Vector3d& pm, const Eigen::Vector3d& rk,
                                       const Eigen::Vector3d& force, const Eigen::Vector3d& moment_at_rk, double h) {
  const Eigen::Vector3d d3 = rm.col(2);
  const Eigen::Vector3d m_mid = moment_at_rk + (rk - pm).cross(force);
  const Eigen::Vector3d d3xf = d3.cross(force);
  const Eigen::Matrix3d sf = skew(force);
  const Eigen::Matrix3d sm = skew(m_mid);
  SectionLinearization s;
  s.p.topRows<3>() = h * rm.transpose() * (sm - sf * skew(pm - rk));
  s.p.row(3) = h * d3xf.transpose();
  s.q.topRows<3>() = h * rm.transpose();
  s.q.row(3).setZero();
  s.f.topRows<3>() = h * rm.transpose() * skew(rk - pm);
  s.f.row(3) = h * d3.transpose();
  const double qh2 = 0.25 * h * h;
  s.x.topLeftCorner<3, 3>() = qh2 * rm.transpose() * sm * rm;
  s.x.bottomLeftCorner<1, 3>() = qh2 * d3xf.transpose() * rm;
  s.x.topRightCorner<3, 1>() = qh2 * rm.transpose() * sf * d3;
  s.x(3, 3) = 0.0;
  return s;
}

constexpr int Q = kNewtonStrain;
constexpr int PHI = kNewtonRotation;
constexpr int R = kNewtonPosition;
constexpr int M = kNewtonMoment;
constexpr int F = kNewtonForce;

void accumulate_distal_loads(RodPoses<const double> poses, Vec3View<const double> node_force,
                             Vec3View<const double> node_moment, Vec3View<double> distal_force,
                             Vec3View<double> distal_moment) {
  const std::size_t n = poses.node_count();
  // Loads beyond each node: F_k, and M_k about r_k.
  Eigen::Vector3d f = Eigen::Vector3d::Zero();
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  distal_force.set(n - 1, f);
  distal_moment.set(n - 1, m);
  for (std::size_t k = n - 1; k-- > 0;) {
    // M_k = M_{k+1} + m_{k+1} + (r_{k+1} − r_k) × F_k,  F_k = F_{k+1} + f_{k+1}
    f += node_force.get(k + 1);
    m += node_moment.get(k + 1) + (poses.node_position.get(k + 1) - poses.node_position.get(k)).cross(f);
    distal_force.set(k, f);
    distal_moment.set(k, m);
  }
}

// Rows 0–3 of node k, the law's part: −M A (a linear law) or −M T (the nodal tangent of a nonlinear one).
void add_law_rows(std::size_t k, std::size_t sections, double h_prev, double h_next,
                  const std::array<double, 4>& law_total, const NodalLawTangent& nodal, NewtonBlock& lo,
                  NewtonBlock& di, NewtonBlock& up) {
  if (nodal.tangent.data.empty()) {
    for (int c = 0; c < 4; ++c) {
      const double a = law_total[static_cast<std::size_t>(c)];
      di(Q + c, Q + c) -= a * (h_prev + h_next) / 3.0;
      if (k > 0) lo(Q + c, Q + c) -= a * h_prev / 6.0;
      if (k < sections) up(Q + c, Q + c) -= a * h_next / 6.0;
    }
  } else {
    // −M T: column node j carries its own tangent T_j (a nonlinear law).
    for (int c = 0; c < 4; ++c) {
      const auto cc = static_cast<std::size_t>(c);
      di(Q + c, Q + c) -= nodal.tangent.at(k, cc) * (h_prev + h_next) / 3.0;
      if (k > 0) lo(Q + c, Q + c) -= nodal.tangent.at(k - 1, cc) * h_prev / 6.0;
      if (k < sections) up(Q + c, Q + c) -= nodal.tangent.at(k + 1, cc) * h_next / 6.0;
    }
    const double bd = nodal.bend_coupling[k] * (h_prev + h_next) / 3.0;
    di(Q, Q + 1) -= bd;
    di(Q + 1, Q) -= bd;
    if (k > 0) {
      const double bl = nodal.bend_coupling[k - 1] * h_prev / 6.0;
      lo(Q, Q + 1) -= bl;
      lo(Q + 1, Q) -= bl;
    }
    if (k < sections) {
      const double bu = nodal.bend_coupling[k + 1] * h_next / 6.0;
      up(Q, Q + 1) -= bu;
      up(Q + 1, Q) -= bu;
    }
  }
}

void add_kinematics_rows(std::size_t k, RodPoses<const double> poses, double h_prev, bool free_base,
                         const NewtonLoadStiffness& stiffness, NewtonBlock& lo, NewtonBlock& di) {
  const bool has_stiffness = !stiffness.force.empty();
  const Eigen::Vector3d rk = poses.node_position.get(k);
  // Rows 4–9: kinematics of section k−1, or the base.
  if (k == 0 && free_base) {
    // Total wrench about node 0 vanishes: M_0 + m_0 = 0, F_0 + f_0 = 0, with node 0's drag
    // depending on its own motion (the drag of node 0 has no lever arm about itself).
    di.block<3, 3>(PHI, M).setIdentity();
    di.block<3, 3>(R, F).setIdentity();
    if (has_stiffness) {
      di.block<3, 3>(PHI, PHI) = -stiffness.moment[0] * Eigen::Matrix3d::Identity();
      di.block<3, 3>(R, R) = -stiffness.force[0];
    }
  } else {
    di.block<3, 3>(PHI, PHI).setIdentity();
    di.block<3, 3>(R, R).setIdentity();
  }
  if (k > 0) {
    const Eigen::Matrix3d rm = poses.mid_rotation.get(k - 1).toRotationMatrix();
    const Eigen::Vector3d d3 = rm.col(2);
    const Eigen::Vector3d dr = rk - poses.node_position.get(k - 1);
    const Eigen::Vector3d lever = rk - poses.mid_position.get(k - 1);
    const Eigen::Matrix3d rot_q = 0.5 * h_prev * rm;    // δφ per δq_u of either node
    const Eigen::Matrix3d pos_q = skew(lever) * rot_q;  // δr per δq_u
    const Eigen::Vector3d pos_e = -0.5 * h_prev * d3;   // δr per δq_ε (row sign)
    lo.block<3, 3>(PHI, PHI) = -Eigen::Matrix3d::Identity();
    lo.block<3, 3>(PHI, Q) = -rot_q;
    di.block<3, 3>(PHI, Q) = -rot_q;
    lo.block<3, 3>(R, R) = -Eigen::Matrix3d::Identity();
    lo.block<3, 3>(R, PHI) = skew(dr);
    lo.block<3, 3>(R, Q) = pos_q;
    di.block<3, 3>(R, Q) = pos_q;
    lo.block<3, 1>(R, Q + 3) = pos_e;
    di.block<3, 1>(R, Q + 3) = pos_e;
  }
}

void add_transport_rows(std::size_t k, std::size_t sections, RodPoses<const double> poses,
                        Vec3View<const double> distal_force, const NewtonLoadStiffness& stiffness, NewtonBlock& di,
                        NewtonBlock& up) {
  const bool has_stiffness = !stiffness.force.empty();
  const Eigen::Vector3d rk = poses.node_position.get(k);
  // Rows 10–15: moment and force transport to the next node, or δM_N = δF_N = 0.
  di.block<3, 3>(M, M).setIdentity();
  di.block<3, 3>(F, F).setIdentity();
  if (k < sections) {
    const Eigen::Matrix3d sf = skew(distal_force.get(k));
    di.block<3, 3>(M, R) = -sf;
    di.block<3, 3>(M, F) = -skew(poses.node_position.get(k + 1) - rk);
    up.block<3, 3>(M, M) = -Eigen::Matrix3d::Identity();
    up.block<3, 3>(M, R) = sf;
    up.block<3, 3>(F, F) = -Eigen::Matrix3d::Identity();
    if (has_stiffness) {
      // δm_{k+1} = −s δφ_{k+1} and δf_{k+1} = −K δr_{k+1} enter the distal sums.
      up.block<3, 3>(M, PHI) = stiffness.moment[k + 1] * Eigen::Matrix3d::Identity();
      up.block<3, 3>(F, R) = stiffness.force[k + 1];
    }
  }
}

}  // namespace

Eigen::Matrix<double, 6, 1> rod_newton_assemble(RodPoses<const double> poses, std::span<const double> section_length,
                                                Vec3View<const double> node_force, Vec3View<const double> node_moment,
                                                const std::array<double, 4>& law_total, NewtonLoadStiffness stiffness,
                                                bool free_base, Vec3View<double> distal_force,
                                                Vec3View<double> distal_moment, NewtonSystem system,
                                                NodalLawTangent nodal) {
  const std::size_t n = poses.node_count();
  const std::size_t sections = n - 1;

  accumulate_distal_loads(poses, node_force, node_moment, distal_force, distal_moment);

  for (std::size_t k = 0; k < n; ++k) {
    system.lower[k].setZero();
    system.diag[k].setZero();
    system.upper[k].setZero();
  }

  std::array<SectionLinearization, 2> lin{};  // [0] section k−1, [1] section k
  for (std::size_t k = 0; k < n; ++k) {
    NewtonBlock& lo = system.lower[k];
    NewtonBlock& di = system.diag[k];
    NewtonBlock& up = system.upper[k];
    const Eigen::Vector3d rk = poses.node_position.get(k);
    if (k + 1 < n) {
      lin[1] = linearize_section(poses.mid_rotation.get(k).toRotationMatrix(), poses.mid_position.get(k), rk,
                                 distal_force.get(k), distal_moment.get(k), section_length[k]);
    }
    const double h_prev = k > 0 ? section_length[k - 1] : 0.0;
    const double h_next = k < sections ? section_length[k] : 0.0;

    add_law_rows(k, sections, h_prev, h_next, law_total, nodal, lo, di, up);
    if (k > 0) {
      lo.block<4, 4>(Q, Q) += 0.5 * lin[0].x;
      lo.block<4, 3>(Q, PHI) += 0.5 * lin[0].p;
      lo.block<4, 3>(Q, M) += 0.5 * lin[0].q;
      lo.block<4, 3>(Q, F) += 0.5 * lin[0].f;
      di.block<4, 4>(Q, Q) += 0.5 * lin[0].x;
    }
    if (k < sections) {
      di.block<4, 4>(Q, Q) += 0.5 * lin[1].x;
      di.block<4, 3>(Q, PHI) += 0.5 * lin[1].p;
      di.block<4, 3>(Q, M) += 0.5 * lin[1].q;
      di.block<4, 3>(Q, F) += 0.5 * lin[1].f;
      up.block<4, 4>(Q, Q) += 0.5 * lin[1].x;
    }

    add_kinematics_rows(k, poses, h_prev, free_base, stiffness, lo, di);
    add_transport_rows(k, sections, poses, distal_force, stiffness, di, up);
    lin[0] = lin[1];
  }
  Eigen::Matrix<double, 6, 1> total;
  total.head<3>() = distal_moment.get(0) + node_moment.get(0);
  total.tail<3>() = distal_force.get(0) + node_force.get(0);
  return total;
}

void rod_strain_residual(StrainView<const double> generalized_force, StrainView<const double> strain,
                         StrainView<const double> target, std::span<const double> section_length,
                         const std::array<double, 4>& law_total, StrainView<double> residual) {
  const std::size_t n = strain.size();
  // residual ← q − q*, then A(q − q*) via the mass matrix, then R − A(q − q*).
  for (std::size_t i = 0; i < 4 * n; ++i) residual.data[i] = strain.data[i] - target.data[i];
  // mass_matrix_multiply needs distinct input and output: go node by node with a rolling window.
  Eigen::Vector4d prev = Eigen::Vector4d::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector4d cur = residual.get(k);
    const Eigen::Vector4d next = k + 1 < n ? residual.get(k + 1) : Eigen::Vector4d::Zero();
    const double h_prev = k > 0 ? section_length[k - 1] : 0.0;
    const double h_next = k + 1 < n ? section_length[k] : 0.0;
    Eigen::Vector4d mx = (h_prev + h_next) / 3.0 * cur + h_prev / 6.0 * prev + h_next / 6.0 * next;
    for (int c = 0; c < 4; ++c) mx[c] *= law_total[static_cast<std::size_t>(c)];
    residual.set(k, generalized_force.get(k) - mx);
    prev = cur;
  }
}

void rod_stress_residual(StrainView<const double> generalized_force, StrainView<const double> stress,
                         std::span<const double> section_length, StrainView<double> residual) {
  mass_matrix_multiply(section_length, stress, residual);
  for (std::size_t i = 0; i < residual.data.size(); ++i)
    residual.data[i] = generalized_force.data[i] - residual.data[i];
}

}  // namespace haustra::kernels
