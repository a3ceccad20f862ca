// Collision stages: beads follow nodes, broad and narrow phase, penalty forces and their stiffness, the
// report.
#include "step/collision.hpp"

#include <algorithm>
#include <cmath>

#include "haustra/kernels/contact_geometry.hpp"
#include "model/static_meshes.hpp"

namespace haustra::detail {
namespace {

constexpr std::size_t kChunk = 64;    // beads per task: fixed, so the split does not depend on threads
constexpr double kSpeculation = 1.5;  // a bead's reach: the margin plus this times its last motion

std::size_t chunks_of(std::size_t n) { return (n + kChunk - 1) / kChunk; }

Eigen::Vector3d node_position(const WorldState& state, std::uint32_t node) {
  return {state.now.position.x[node], state.now.position.y[node], state.now.position.z[node]};
}

// Penalty coefficient (× E) of a candidate: the harmonic mean of two tissues' moduli.
double stiffness_of(const WorldModel& model, const ContactCandidate& c) {
  const double e = model.beads.modulus[c.bead];
  if (c.kind != ContactKind::bead) return model.contact.coefficient * e;
  const double f = model.beads.modulus[c.other];
  return model.contact.coefficient * 2.0 * e * f / (e + f);
}

Eigen::Vector3d instrument_end(const InstrumentState& s, const InstrumentModel& d) { return s.tip + d.length * s.axis; }

// Depth and separating direction of a candidate for a bead at c (and, for two beads, the other at o).
kernels::SphereContact measure(const WorldModel& model, const WorldState& state, const ContactCandidate& k,
                               const Eigen::Vector3d& c) {
  const double r = model.beads.radius[k.bead];
  switch (k.kind) {
    case ContactKind::bead:
      return kernels::sphere_sphere(c, r, node_position(state, model.beads.node[k.other]), model.beads.radius[k.other]);
    case ContactKind::plane:
    case ContactKind::mesh: return kernels::sphere_plane(c, r, k.point, k.normal);
    case ContactKind::sphere: {
      const EnvironmentModel::Sphere& s = model.environment.spheres[k.other];
      return kernels::sphere_sphere(c, r, s.center, s.radius);
    }
    case ContactKind::capsule: {
      const EnvironmentModel::Capsule& s = model.environment.capsules[k.other];
      return kernels::sphere_capsule(c, r, s.a, s.b, s.radius);
    }
    case ContactKind::instrument: {
      const InstrumentState& s = state.instruments[k.other];
      const InstrumentModel& d = model.instruments[k.other];
      return kernels::sphere_capsule(c, r, s.tip, instrument_end(s, d), d.radius);
    }
  }
  return {};
}

// Environment and instrument candidates of one bead, appended to `out`.
void environment_candidates(const WorldModel& model, const WorldState& state, std::uint32_t b,
                            std::vector<ContactCandidate>& out) {
  const Eigen::Vector3d c = state.collision.bead_center.view().get(b);
  const double r = model.beads.radius[b];
  const double margin = model.contact.margin + kSpeculation * state.collision.bead_motion[b];
  const EnvironmentModel& env = model.environment;
  auto add = [&](ContactKind kind, std::size_t other, const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
    ContactCandidate k;
    k.bead = b;
    k.other = static_cast<std::uint32_t>(other);
    k.kind = kind;
    k.point = point;
    k.normal = normal;
    out.push_back(k);
  };
  for (std::size_t i = 0; i < env.planes.size(); ++i)
    if (kernels::sphere_plane(c, r, env.planes[i].point, env.planes[i].normal).depth > -margin)
      add(ContactKind::plane, i, env.planes[i].point, env.planes[i].normal);
  for (std::size_t i = 0; i < env.spheres.size(); ++i)
    if (kernels::sphere_sphere(c, r, env.spheres[i].center, env.spheres[i].radius).depth > -margin)
      add(ContactKind::sphere, i, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  for (std::size_t i = 0; i < env.capsules.size(); ++i)
    if (kernels::sphere_capsule(c, r, env.capsules[i].a, env.capsules[i].b, env.capsules[i].radius).depth > -margin)
      add(ContactKind::capsule, i, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  if (model.meshes && model.meshes->size() > 0) {
    const StaticMeshes::Hit hit = model.meshes->closest(c, r + margin);
    // The tangent plane at the closest point stands in for the mesh during the frame.
    if (hit.found) add(ContactKind::mesh, hit.mesh, hit.point, hit.push);
    // Each container on its own: a bead near the body's wall may also touch an organ inside it.
    for (std::size_t i = 0; i < model.meshes->container_count(); ++i) {
      const StaticMeshes::Hit held = model.meshes->container_contact(i, c, r + margin);
      if (held.found) add(ContactKind::mesh, held.mesh, held.point, held.push);
    }
  }
  for (std::size_t i = 0; i < model.instruments.size(); ++i) {
    if (instrument_holds(state, i, b)) continue;  // the grasped bead sits in the jaws
    const InstrumentState& s = state.instruments[i];
    // A proxy may move towards its command within the frame: its capsule reaches that much further.
    if (kernels::sphere_capsule(c, r, s.tip, instrument_end(s, model.instruments[i]), model.instruments[i].radius)
            .depth > -(margin + s.reach))
      add(ContactKind::instrument, i, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  }
}

}  // namespace

bool instrument_holds(const WorldState& state, std::size_t instrument, std::uint32_t bead) {
  const InstrumentState& s = state.instruments[instrument];
  return s.grasping && s.grasp_bead == bead;
}

void init_collision_state(const WorldModel& model, WorldState& state) {
  CollisionState& cs = state.collision;
  const std::size_t nb = model.beads.size();
  cs.bead_center.resize(nb);
  cs.bead_position.resize(nb);
  cs.bead_motion.assign(nb, 0.0);
  cs.reach_radius.assign(nb, 0.0);
  cs.bead_force.resize(nb);
  cs.bead_stiffness.assign(nb, Eigen::Matrix3d::Zero());
  cs.bead_contact_start.assign(nb + 1, 0);
  cs.coupled_start.assign(model.segments.size() + 1, 0);
  cs.coupled_fill.assign(model.segments.size(), 0);
  cs.coupled.reserve(kMaxCoupledContacts * model.segments.size());
  const std::size_t chunks = chunks_of(nb);
  cs.chunk_pairs.assign(chunks, {});
  cs.chunk_candidates.assign(chunks, {});
  cs.chunk_count.assign(chunks, 0);
  // Room for a dense pile (a dozen neighbours per bead) before anything grows.
  for (auto& v : cs.chunk_pairs) v.resize(16 * kChunk);
  for (auto& v : cs.chunk_candidates) v.reserve(4 * kChunk);
  cs.candidates.reserve(16 * nb + 64);
  cs.bead_contact.reserve(32 * nb + 64);
  cs.pairs.resize(16 * nb + 64);
}

namespace {

// Bead pairs within reach, ascending (a, b), into cs.pairs: a grid in chunks over the scheduler,
// or one brute-force pass; returns their count.
std::size_t bead_pairs(const WorldModel& model, const kernels::SphereSet& set, double margin, CollisionState& cs,
                       Scheduler& scheduler) {
  const std::size_t nb = model.beads.size();
  const std::size_t chunks = chunks_of(nb);
  const BroadPhase method = model.contact.broad_phase;  // resolved by the model
  std::size_t pair_count = 0;
  if (method == BroadPhase::grid) {
    cs.grid.build(set, margin);
    scheduler.for_each(chunks, [&](std::size_t c) {
      const std::size_t first = c * kChunk, last = std::min(nb, first + kChunk);
      std::vector<kernels::SpherePair>& out = cs.chunk_pairs[c];
      std::size_t n = cs.grid.query(set, first, last, out);
      if (n > out.size()) {  // a denser pile than ever before: grow once and redo
        out.resize(2 * n);
        n = cs.grid.query(set, first, last, out);
      }
      cs.chunk_count[c] = n;
    });
    for (std::size_t c = 0; c < chunks; ++c) pair_count += cs.chunk_count[c];
    if (cs.pairs.size() < pair_count) cs.pairs.resize(2 * pair_count);
    std::size_t at = 0;
    for (std::size_t c = 0; c < chunks; ++c) {
      std::copy_n(cs.chunk_pairs[c].begin(), cs.chunk_count[c], cs.pairs.begin() + static_cast<std::ptrdiff_t>(at));
      at += cs.chunk_count[c];
    }
  } else {
    for (;;) {
      pair_count = kernels::broad_phase_brute(set, margin, cs.pairs);
      if (pair_count <= cs.pairs.size()) break;
      cs.pairs.resize(2 * pair_count);
    }
  }
  return pair_count;
}

// Per bead, the candidates it takes part in, in candidate order (CSR: bead_contact_start, and
// each entry the candidate's index times two, plus one when the bead is the pair's second).
void index_bead_contacts(CollisionState& cs, std::size_t nb) {
  std::fill(cs.bead_contact_start.begin(), cs.bead_contact_start.end(), 0u);
  for (const ContactCandidate& k : cs.candidates) {
    ++cs.bead_contact_start[k.bead + 1];
    if (k.kind == ContactKind::bead) ++cs.bead_contact_start[k.other + 1];
  }
  for (std::size_t b = 0; b < nb; ++b) cs.bead_contact_start[b + 1] += cs.bead_contact_start[b];
  cs.bead_contact.resize(cs.bead_contact_start[nb]);
  for (std::size_t i = 0; i < cs.candidates.size(); ++i) {
    const ContactCandidate& k = cs.candidates[i];
    cs.bead_contact[cs.bead_contact_start[k.bead]++] = static_cast<std::uint32_t>(i << 1);
    if (k.kind == ContactKind::bead)
      cs.bead_contact[cs.bead_contact_start[k.other]++] = static_cast<std::uint32_t>((i << 1) | 1);
  }
  for (std::size_t b = nb; b > 0; --b) cs.bead_contact_start[b] = cs.bead_contact_start[b - 1];
  cs.bead_contact_start[0] = 0;
}

}  // namespace

void stage_collide(const WorldModel& model, WorldState& state, Scheduler& scheduler) {
  CollisionState& cs = state.collision;
  const BeadModel& beads = model.beads;
  const std::size_t nb = beads.size();
  for (std::size_t b = 0; b < nb; ++b) {
    cs.bead_center.view().set(b, node_position(state, beads.node[b]));
    cs.reach_radius[b] = beads.radius[b] + 0.5 * model.contact.margin + kSpeculation * cs.bead_motion[b];
  }
  // Pairs within reach: each bead's radius grown by its share of the margin and its speculation.
  const kernels::SphereSet set{cs.bead_center.x, cs.bead_center.y, cs.bead_center.z, cs.reach_radius};
  const double margin = 0.0;
  const std::size_t chunks = chunks_of(nb);

  const std::size_t pair_count = bead_pairs(model, set, margin, cs, scheduler);

  cs.candidates.clear();
  for (std::size_t p = 0; p < pair_count; ++p) {
    const kernels::SpherePair& pr = cs.pairs[p];
    if (beads.segment[pr.a] == beads.segment[pr.b] && (!model.contact.self || beads.excluded(pr.a, pr.b))) continue;
    if (beads.segment[pr.a] != beads.segment[pr.b] && model.contact.rest_exclusions == RestExclusions::world &&
        beads.excluded(pr.a, pr.b))
      continue;
    ContactCandidate k;
    k.bead = pr.a;
    k.other = pr.b;
    k.kind = ContactKind::bead;
    cs.candidates.push_back(k);
  }
  // Environment and instruments, bead by bead, in chunks concatenated in order.
  scheduler.for_each(chunks, [&](std::size_t c) {
    std::vector<ContactCandidate>& out = cs.chunk_candidates[c];
    out.clear();
    const std::size_t first = c * kChunk, last = std::min(nb, first + kChunk);
    for (std::size_t b = first; b < last; ++b) environment_candidates(model, state, static_cast<std::uint32_t>(b), out);
  });
  for (std::size_t c = 0; c < chunks; ++c)
    cs.candidates.insert(cs.candidates.end(), cs.chunk_candidates[c].begin(), cs.chunk_candidates[c].end());

  index_bead_contacts(cs, nb);
  cs.report.candidates = cs.candidates.size();
}

// For the Newton linearization: a quadratic penalty has almost no stiffness just after first
// touch, so a touching bead is linearized with at least the stiffness it would have at this
// fraction of its radius deep. A candidate that does not touch has neither force nor stiffness: a
// Jacobian stiffer than the rod makes every constraint force computed against it overshoot.
constexpr double kLinearizationDepth = 0.02;

void stage_contacts(const WorldModel& model, WorldState& state, Scheduler& scheduler) {
  CollisionState& cs = state.collision;
  const std::size_t n = cs.candidates.size();
  const double exponent = model.contact.exponent;
  scheduler.for_each(chunks_of(n), [&](std::size_t c) {
    const std::size_t last = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < last; ++i) {
      ContactCandidate& k = cs.candidates[i];
      const kernels::SphereContact m = measure(model, state, k, node_position(state, model.beads.node[k.bead]));
      const double coefficient = stiffness_of(model, k);
      const kernels::Penalty p = kernels::contact_penalty(m.depth, coefficient, exponent);
      k.depth = m.depth;
      k.direction = m.normal;
      k.force = p.force * m.normal;
      k.stiffness = 0.0;
      if (m.depth > 0.0) {  // (most candidates do not touch: no power taken for them)
        const kernels::Penalty floor =
            kernels::contact_penalty(kLinearizationDepth * model.beads.radius[k.bead], coefficient, exponent);
        // Two beads both move: each side sees the pair's stiffness twice, so that their combined
        // correction is not doubled (one side held still then under-corrects, which converges).
        k.stiffness = std::max(p.stiffness, floor.stiffness) * (k.kind == ContactKind::bead ? 2.0 : 1.0);
      }
      k.coupled = false;
    }
  });
  // The touching pairs within one segment that Newton couples exactly, in candidate order.
  const std::size_t segs = model.segments.size();
  std::fill(cs.coupled_start.begin(), cs.coupled_start.end(), 0u);
  // (Fast mode couples none: its factorization serves while the touching set stands, and a pair's
  // column would need its responses anew each time.)
  const bool couple = model.solver.mode != SolverMode::fast;
  for (ContactCandidate& k : cs.candidates) {
    if (!couple || k.kind != ContactKind::bead || k.depth <= 0.0) continue;
    const std::uint32_t sa = model.beads.segment[k.bead];
    if (sa != model.beads.segment[k.other] || cs.coupled_start[sa + 1] >= kMaxCoupledContacts) continue;
    // A bead of a sleeping range is held (decision 0127): its pair is a contact on a fixed bead.
    const HeldRange held = state.held_range(sa);
    const std::size_t first = model.segments[sa].node_offset + held.first, last = first + held.last - held.first;
    auto in_range = [&](std::uint32_t bead) {
      return model.beads.node[bead] >= first && model.beads.node[bead] <= last;
    };
    if (held.any() && (in_range(k.bead) || in_range(k.other))) continue;
    k.coupled = true;
    k.stiffness *= 0.5;  // the pair's own stiffness: both beads are in the solve
    ++cs.coupled_start[sa + 1];
  }
  for (std::size_t g = 0; g < segs; ++g) cs.coupled_start[g + 1] += cs.coupled_start[g];
  cs.coupled.resize(cs.coupled_start[segs]);
  std::copy(cs.coupled_start.begin(), cs.coupled_start.end() - 1, cs.coupled_fill.begin());
  for (std::size_t i = 0; i < cs.candidates.size(); ++i)
    if (cs.candidates[i].coupled)
      cs.coupled[cs.coupled_fill[model.beads.segment[cs.candidates[i].bead]]++] = static_cast<std::uint32_t>(i);
  const std::size_t nb = model.beads.size();
  scheduler.for_each(chunks_of(nb), [&](std::size_t c) {
    const std::size_t last = std::min(nb, (c + 1) * kChunk);
    for (std::size_t b = c * kChunk; b < last; ++b) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero();
      Eigen::Matrix3d k = Eigen::Matrix3d::Zero();
      for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e) {
        const ContactCandidate& kc = cs.candidates[cs.bead_contact[e] >> 1];
        const bool second = (cs.bead_contact[e] & 1U) != 0;
        f += second ? Eigen::Vector3d(-kc.force) : kc.force;
        if (!kc.coupled) k += kc.stiffness * kc.direction * kc.direction.transpose();
      }
      cs.bead_force.view().set(b, f);
      cs.bead_stiffness[b] = k;
    }
  });
}

double segment_contact_potential(const WorldModel& model, const WorldState& state, std::size_t segment,
                                 std::span<const Eigen::Vector3d> bead_start, std::size_t first, std::size_t end,
                                 bool across) {
  const SegmentModel& seg = model.segments[segment];
  const CollisionState& cs = state.collision;
  if (cs.bead_contact_start.empty()) return 0.0;
  const double exponent = model.contact.exponent;
  auto inside = [&](std::uint32_t bead) {
    const std::size_t k = model.beads.node[bead] - seg.node_offset;
    return k >= first && k < end;
  };
  double potential = 0.0;
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count; ++b) {
    if (!inside(static_cast<std::uint32_t>(b))) continue;
    const Eigen::Vector3d c = node_position(state, model.beads.node[b]);
    for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e) {
      const ContactCandidate& k = cs.candidates[cs.bead_contact[e] >> 1];
      const bool second = (cs.bead_contact[e] & 1U) != 0;
      const std::uint32_t mate = second ? k.bead : k.other;
      const bool mate_here = k.kind == ContactKind::bead && model.beads.segment[mate] == segment;
      const bool spans = mate_here && !inside(mate);
      if (spans != across) continue;
      if (second && mate_here && !spans) continue;  // counted from its first bead
      double depth = 0.0;
      if (mate_here || (k.kind != ContactKind::bead)) {
        depth = measure(model, state, k, node_position(state, model.beads.node[k.bead])).depth;
      } else {
        const Eigen::Vector3d moved = c - bead_start[b - seg.bead_offset];
        depth = k.depth - (second ? -1.0 : 1.0) * k.direction.dot(moved);
      }
      if (depth > 0.0) {
        const double power =
            exponent == 2.0 ? depth * depth * depth : std::pow(depth, exponent + 1.0);  // the paper's d²
        potential += stiffness_of(model, k) * power / (exponent + 1.0);
      }
    }
  }
  return potential;
}

bool held_by_container(const WorldModel& model, const ContactCandidate& c) {
  return c.kind == ContactKind::mesh && model.environment.mesh_container[c.other] != 0;
}

double depth_at_frame_start(const WorldModel& model, const WorldState& state, const ContactCandidate& c) {
  const std::uint32_t node = model.beads.node[c.bead];
  return measure(model, state, c, state.frame_start.position.view().get(node)).depth;
}

double container_release(const WorldModel& model, const WorldState& state, std::size_t segment) {
  const SegmentModel& seg = model.segments[segment];
  const CollisionState& cs = state.collision;
  const double exponent = model.contact.exponent;
  auto potential = [&](const ContactCandidate& k, double depth) {
    return depth > 0.0 ? stiffness_of(model, k) * std::pow(depth, exponent + 1.0) / (exponent + 1.0) : 0.0;
  };
  double released = 0.0;
  for (std::size_t b = seg.bead_offset; b < seg.bead_offset + seg.bead_count && !cs.bead_contact_start.empty(); ++b)
    for (std::uint32_t e = cs.bead_contact_start[b]; e < cs.bead_contact_start[b + 1]; ++e) {
      const ContactCandidate& k = cs.candidates[cs.bead_contact[e] >> 1];
      if (!held_by_container(model, k)) continue;
      const double now = measure(model, state, k, node_position(state, model.beads.node[k.bead])).depth;
      released += std::max(0.0, potential(k, depth_at_frame_start(model, state, k)) - potential(k, now));
    }
  return released;
}

void record_bead_motion(const WorldModel& model, WorldState& state) {
  CollisionState& cs = state.collision;
  for (std::size_t b = 0; b < model.beads.size(); ++b)
    cs.bead_motion[b] = (node_position(state, model.beads.node[b]) - cs.bead_center.view().get(b)).norm();
}

void stage_contact_report(const WorldModel& model, WorldState& state) {
  CollisionState& cs = state.collision;
  ContactReport& r = cs.report;
  r.touching = 0;
  r.max_environment_depth = r.max_environment_depth_ratio = 0.0;
  r.max_bead_overlap = r.max_bead_overlap_ratio = 0.0;
  for (ContactCandidate& k : cs.candidates) {
    const Eigen::Vector3d centre = node_position(state, model.beads.node[k.bead]);
    const kernels::SphereContact m = measure(model, state, k, centre);
    // For the host (the frame's solve is done with it): where the other surface comes nearest the
    // bead's centre — on a plane, the foot of the centre — instead of the plane's reference point.
    k.point = centre - (model.beads.radius[k.bead] - m.depth) * m.normal;
    if (m.depth <= 0.0) continue;
    ++r.touching;
    if (k.kind == ContactKind::bead) {
      const double smaller = std::min(model.beads.radius[k.bead], model.beads.radius[k.other]);
      r.max_bead_overlap = std::max(r.max_bead_overlap, m.depth);
      r.max_bead_overlap_ratio = std::max(r.max_bead_overlap_ratio, m.depth / smaller);
    } else {
      r.max_environment_depth = std::max(r.max_environment_depth, m.depth);
      r.max_environment_depth_ratio = std::max(r.max_environment_depth_ratio, m.depth / model.beads.radius[k.bead]);
    }
  }
}

}  // namespace haustra::detail
