// Instruments as proxies: each capsule's tip at the minimum of its coupling's and contacts' energy.
#include "step/instrument_proxy.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/kernels/virtual_coupling.hpp"
#include "model/static_meshes.hpp"
#include "step/instruments.hpp"

namespace haustra::detail {
namespace {

// The environment holds the tip this many times stiffer than the coupling pulls: at the force
// limit the tip sits limit / (k × this) inside a wall (80 µm at the defaults).
constexpr double kEnvironmentStiffness = 100.0;
constexpr int kMaxNewton = 40;
constexpr int kMaxHalvings = 30;

// The proxy's potential at tip p, its gradient and (Gauss–Newton) Hessian.
struct ProxyEnergy {
  double value = 0.0;
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();
  Eigen::Vector3d coupling_force = Eigen::Vector3d::Zero();  // the coupling's pull on the proxy
};

struct ProxyProblem {
  const WorldModel& model;
  const WorldState& state;
  std::size_t instrument;
  Eigen::Vector3d target;  // the spring's and damper's weighted target
  double stiffness;        // k + b/Δt
  double limit;            // what the grasp leaves of the force limit
  double environment;      // the environment's stiffness on the tip

  // A penalty ½ k depth² pushing the tip out along `out` (depth > 0 inside).
  void add_wall(ProxyEnergy& e, double depth, const Eigen::Vector3d& out) const {
    if (depth <= 0.0) return;
    e.value += 0.5 * environment * depth * depth;
    e.gradient -= environment * depth * out;
    e.hessian += environment * out * out.transpose();
  }

  ProxyEnergy evaluate(const Eigen::Vector3d& p) const {
    ProxyEnergy e;
    const kernels::CouplingResponse c = kernels::virtual_coupling(p, target, stiffness, limit);
    e.value = c.energy;
    e.gradient = -c.force;
    e.hessian = c.stiffness;
    e.coupling_force = c.force;
    const InstrumentModel& d = model.instruments[instrument];
    const InstrumentState& s = state.instruments[instrument];
    const Eigen::Vector3d end = p + d.length * s.axis;
    // The beads it meets, with the paper's penalty (its energy c E d^(e+1) / (e+1)).
    const double exponent = model.contact.exponent;
    for (const ContactCandidate& k : state.collision.candidates) {
      if (k.kind != ContactKind::instrument || k.other != instrument) continue;
      const Eigen::Vector3d centre = state.now.position.view().get(model.beads.node[k.bead]);
      const kernels::SphereContact sc = kernels::sphere_capsule(centre, model.beads.radius[k.bead], p, end, d.radius);
      if (sc.depth <= 0.0) continue;
      const double ce = model.contact.coefficient * model.beads.modulus[k.bead];
      const double force = ce * std::pow(sc.depth, exponent);
      e.value += force * sc.depth / (exponent + 1.0);
      e.gradient += force * sc.normal;  // moving the capsule towards the bead deepens it
      e.hessian += exponent * ce * std::pow(sc.depth, exponent - 1.0) * sc.normal * sc.normal.transpose();
    }
    // The tip against the environment (the shaft passes the body wall through its port).
    const EnvironmentModel& env = model.environment;
    for (const EnvironmentModel::Plane& pl : env.planes) {
      const kernels::SphereContact sc = kernels::sphere_plane(p, d.radius, pl.point, pl.normal);
      add_wall(e, sc.depth, sc.normal);
    }
    for (const EnvironmentModel::Sphere& sp : env.spheres) {
      const kernels::SphereContact sc = kernels::sphere_sphere(p, d.radius, sp.center, sp.radius);
      add_wall(e, sc.depth, sc.normal);
    }
    for (const EnvironmentModel::Capsule& cp : env.capsules) {
      const kernels::SphereContact sc = kernels::sphere_capsule(p, d.radius, cp.a, cp.b, cp.radius);
      add_wall(e, sc.depth, sc.normal);
    }
    if (model.meshes && model.meshes->size() > 0) {
      const StaticMeshes::Hit hit = model.meshes->closest(p, 2.0 * d.radius + 0.01);
      if (hit.found) add_wall(e, d.radius - hit.signed_distance, hit.push);
      // A container (the body): the tip kept inside it, as beads are.
      for (std::size_t k = 0; k < model.meshes->container_count(); ++k) {
        const StaticMeshes::Hit in = model.meshes->container_contact(k, p, d.radius);
        if (in.found) add_wall(e, d.radius - in.signed_distance, in.push);
      }
    }
    return e;
  }
};

// Newton's method with a backtracking line search on the proxy's potential, from p.
Eigen::Vector3d minimize(const ProxyProblem& problem, Eigen::Vector3d p) {
  ProxyEnergy e = problem.evaluate(p);
  const double scale = problem.model.instruments[problem.instrument].force_limit + 1e-3;
  for (int it = 0; it < kMaxNewton && e.gradient.norm() > 1e-10 * scale; ++it) {
    // A little of the coupling's stiffness keeps the step defined where nothing holds the tip.
    const Eigen::Matrix3d h = e.hessian + 1e-9 * problem.stiffness * Eigen::Matrix3d::Identity();
    const Eigen::Vector3d step = -h.ldlt().solve(e.gradient);
    const double slope = e.gradient.dot(step);
    if (!step.allFinite() || slope >= 0.0) break;
    double alpha = 1.0;
    ProxyEnergy trial = problem.evaluate(p + step);
    for (int k = 0; k < kMaxHalvings && trial.value > e.value + 1e-4 * alpha * slope; ++k) {
      alpha *= 0.5;
      trial = problem.evaluate(p + alpha * step);
    }
    if (trial.value > e.value) break;  // no descent left at this precision
    p += alpha * step;
    e = trial;
    if (alpha * step.norm() < 1e-13) break;
  }
  return p;
}

}  // namespace

double grasp_limit(const InstrumentModel& d, const InstrumentState& s) {
  return is_proxy(d) ? std::max(0.0, d.force_limit - s.proxy_force.norm()) : d.force_limit;
}

void snapshot_instrument_proxies(WorldState& state) {
  for (InstrumentState& s : state.instruments) s.proxy_start = s.tip;
}

double stage_instrument_proxies(const WorldModel& model, WorldState& state, double dt, double frame_dt) {
  double moved = 0.0;
  for (std::size_t i = 0; i < model.instruments.size(); ++i) {
    const InstrumentModel& d = model.instruments[i];
    if (!is_proxy(d)) continue;
    InstrumentState& s = state.instruments[i];
    // Spring to the commanded tip, damper to the command's motion over the substep, as one capped
    // spring to their weighted target (as the grasp's coupling).
    const double spring = d.coupling_stiffness, damper = d.coupling_damping / dt;
    const Eigen::Vector3d moved_with = s.proxy_start + (s.command_tip - s.command_start) * (dt / frame_dt);
    const ProxyProblem problem{model,
                               state,
                               i,
                               (spring * s.command_tip + damper * moved_with) / (spring + damper),
                               spring + damper,
                               d.force_limit,
                               kEnvironmentStiffness * spring};
    const Eigen::Vector3d p = minimize(problem, s.tip);
    moved = std::max(moved, (p - s.tip).norm());
    s.tip = p;
    s.proxy_force = problem.evaluate(p).coupling_force;
    s.grasp_limit = grasp_limit(d, s);
  }
  return moved;
}

}  // namespace haustra::detail
