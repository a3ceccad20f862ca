// Binding an organ mesh to its cage: mean value coordinates localized to the rings of largest weight, or the rod's
// frames.
#include "model/skin_binding.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <numeric>
#include <span>

#include "haustra/kernels/cage_rings.hpp"
#include "haustra/kernels/mean_value_coordinates.hpp"
#include "sched/scheduler.hpp"

namespace haustra::detail {
namespace {

using kernels::kSkinCoefficients;
using kernels::kSkinLanes;

// Per vertex, its kept rings (ascending) and their coefficients (b, A), before packing; vertices
// may keep different numbers of rings.
struct Slots {
  std::vector<std::vector<std::uint32_t>> ring;  // per vertex
  std::vector<std::vector<double>> coef;         // per vertex: 4 per kept ring (b, Ax, Ay, Az)
  void resize(std::size_t vertices) {
    ring.assign(vertices, {});
    coef.assign(vertices, {});
  }
  void set(std::size_t v, std::size_t slot, std::uint32_t g, double b, const Eigen::Vector3d& a) {
    if (ring[v].size() <= slot) {
      ring[v].resize(slot + 1);
      coef[v].resize(4 * (slot + 1));
    }
    ring[v][slot] = g;
    double* c = &coef[v][4 * slot];
    c[0] = b;
    c[1] = a.x();
    c[2] = a.y();
    c[3] = a.z();
  }
};

// Groups vertices into blocks of kSkinLanes (decision 0084): vertices sorted by ring set
// (lexicographically, then by index); a block takes the next vertex while the union of their ring
// sets is at most one ring more than its largest member's and at most `max_rings`, so similar
// sets share a block instead of padding their own. Sets of one size never merge unless equal when
// max_rings is that size (fixed K packs as before). on_block(order, first, end, rings): the block
// is order[first, end), its rings their union.
template <class OnBlock>
void for_each_block(const std::vector<std::vector<std::uint32_t>>& sets, std::size_t max_rings, OnBlock on_block) {
  const std::size_t n = sets.size();
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0U);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return sets[a] < sets[b];  // lexicographic: a set next to the sets it begins
  });
  std::vector<std::uint32_t> merged;
  // Whether a vertex of ring set `add` may join a block of rings `set` whose largest member keeps
  // `largest` rings: the union then has at most one ring more than its largest member's.
  const auto fits = [&](const std::vector<std::uint32_t>& set, std::size_t largest,
                        const std::vector<std::uint32_t>& add) {
    merged.clear();
    std::set_union(set.begin(), set.end(), add.begin(), add.end(), std::back_inserter(merged));
    const std::size_t most = std::max(largest, add.size());
    return merged.size() == most || merged.size() <= std::min(max_rings, most + 1);
  };
  std::size_t i = 0;
  while (i < n) {
    std::vector<std::uint32_t> set = sets[order[i]];
    std::size_t largest = set.size();
    std::size_t j = i + 1;
    while (j < n && j - i < kSkinLanes && fits(set, largest, sets[order[j]])) {
      largest = std::max(largest, sets[order[j]].size());
      set = merged;
      ++j;
    }
    on_block(order, i, j, set);
    i = j;
  }
}

// Packs the vertices' kept rings and coefficients in for_each_block's blocks; a vertex's
// coefficients are zero on the rings of its block it does not keep.
SkinBinding pack(const TriangleMesh& mesh, const Slots& slots, std::size_t max_rings) {
  SkinBinding b;
  b.vertices = mesh.vertices.size();
  b.slot_start.push_back(0);
  for_each_block(slots.ring, max_rings,
                 [&](const std::vector<std::uint32_t>& order, std::size_t i, std::size_t j,
                     const std::vector<std::uint32_t>& set) {
                   const std::size_t slot0 = b.ring.size();
                   b.ring.insert(b.ring.end(), set.begin(), set.end());
                   b.slot_start.push_back(static_cast<std::uint32_t>(b.ring.size()));
                   b.coefficient.resize(b.ring.size() * kSkinCoefficients * kSkinLanes, 0.0f);
                   for (std::size_t l = 0; l < kSkinLanes; ++l) {
                     const bool real = i + l < j;
                     const std::uint32_t v = real ? order[i + l] : kernels::kNoVertex;
                     b.vertex.push_back(v);
                     b.rest_x.push_back(real ? static_cast<float>(mesh.vertices[v].x()) : 0.0f);
                     b.rest_y.push_back(real ? static_cast<float>(mesh.vertices[v].y()) : 0.0f);
                     b.rest_z.push_back(real ? static_cast<float>(mesh.vertices[v].z()) : 0.0f);
                     if (!real) continue;
                     const std::vector<std::uint32_t>& own = slots.ring[v];
                     for (std::size_t k = 0; k < own.size(); ++k) {
                       const auto s =
                           static_cast<std::size_t>(std::lower_bound(set.begin(), set.end(), own[k]) - set.begin());
                       for (std::size_t c = 0; c < kSkinCoefficients; ++c)
                         b.coefficient[((slot0 + s) * kSkinCoefficients + c) * kSkinLanes + l] =
                             static_cast<float>(slots.coef[v][4 * k + c]);
                     }
                   }
                 });
  return b;
}

double rest_error(const SkinBinding& b, const TriangleMesh& mesh) {
  double worst = 0.0;
  for (std::size_t i = 0; i < b.vertex.size(); ++i)
    if (b.vertex[i] != kernels::kNoVertex)
      worst =
          std::max(worst, (Eigen::Vector3d(b.rest_x[i], b.rest_y[i], b.rest_z[i]) - mesh.vertices[b.vertex[i]]).norm());
  return worst;
}

// What skinning costs per vertex: the slots of every block times its lanes (padding included),
// over the vertices.
double slots_per_vertex(const SkinBinding& b) {
  return b.vertices == 0 ? 0.0
                         : static_cast<double>(b.slot_start.back()) * kSkinLanes / static_cast<double>(b.vertices);
}

struct VertexStats {
  double min_weight = 0.0, negative_mass = 0.0, dropped_mass = 0.0, correction = 0.0;
  std::size_t kept = 0;
  kernels::MvcLocation location = kernels::MvcLocation::general;
};

// The rings a vertex keeps (decision 0048): the `at_least` of largest weight mass (ties: lower ring
// first), then more by mass while the mass left out exceeds `weight_left_out` of the total; then in
// ring order. Returns how many rings `order` starts with and the weight mass the others carry.
std::pair<std::size_t, double> choose_rings(const std::vector<double>& mass, std::size_t at_least,
                                            double weight_left_out, std::vector<std::uint32_t>& order) {
  const std::size_t rings = mass.size();
  std::iota(order.begin(), order.end(), 0U);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t c) { return mass[a] != mass[c] ? mass[a] > mass[c] : a < c; });
  double total_mass = 0.0, dropped = 0.0;
  for (std::size_t g = 0; g < rings; ++g) total_mass += mass[g];
  for (std::size_t k = at_least; k < rings; ++k) dropped += mass[order[k]];
  std::size_t keep = at_least;
  while (weight_left_out > 0.0 && keep < rings && dropped > weight_left_out * total_mass)
    dropped -= mass[order[keep++]];
  std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep));
  return {keep, dropped};
}

// Folds the weight of the rings left out onto the kept ones (decision 0083): a left-out ring g's
// share of the vertex, the point b_g c_g + R_g A_g at rest, is carried instead by the kept rings
// nearest it along the rod — split between the two that bracket it, in proportion to their arc
// lengths, or all to the nearer end of the kept ones — so the sum of the weights stays 1 and the
// rest pose is reproduced as by all rings; what it costs is how differently g and its carriers move.
// kept: the kept rings, ascending (ring order is arc order); weight, moment: per ring, updated.
void fold_left_out(const CageModel& cage, std::span<const std::uint32_t> kept, std::vector<double>& weight,
                   std::vector<Eigen::Vector3d>& moment, std::vector<std::uint8_t>& is_kept) {
  const std::size_t rings = weight.size();
  std::fill(is_kept.begin(), is_kept.end(), 0);
  for (const std::uint32_t g : kept) is_kept[g] = 1;
  const auto arc = [&](std::size_t g) { return cage.ring_binding[g].centre.z(); };
  // Moves ring g's share (fraction f of it) onto ring h, as the same point at rest.
  const auto carry = [&](std::size_t g, std::size_t h, double f) {
    const kernels::RingPose &rg = cage.ring_rest[g], &rh = cage.ring_rest[h];
    const double b = f * weight[g];
    moment[h] += rh.rotation.transpose() * (f * (rg.rotation * moment[g]) + b * (rg.centre - rh.centre));
    weight[h] += b;
  };
  std::size_t next = 0;  // index into kept of the first kept ring above g
  for (std::size_t g = 0; g < rings; ++g) {
    while (next < kept.size() && kept[next] <= g) ++next;
    if (is_kept[g] != 0 || (weight[g] == 0.0 && moment[g].isZero())) continue;
    if (next == 0) {
      carry(g, kept.front(), 1.0);
    } else if (next == kept.size()) {
      carry(g, kept.back(), 1.0);
    } else {
      const std::size_t lo = kept[next - 1], hi = kept[next];
      const double span = arc(hi) - arc(lo);
      const double f = span > 0.0 ? std::clamp((arc(hi) - arc(g)) / span, 0.0, 1.0) : 0.5;
      carry(g, lo, f);
      carry(g, hi, 1.0 - f);
    }
    weight[g] = 0.0;
    moment[g].setZero();
  }
}

// The binding's report from each vertex's statistics: the worst and the mean.
SkinReport skin_report_of(const std::vector<VertexStats>& stats) {
  SkinReport report;
  double negative_sum = 0.0, dropped_sum = 0.0, kept_sum = 0.0;
  for (const VertexStats& s : stats) {
    report.rings_per_vertex = std::max(report.rings_per_vertex, s.kept);
    kept_sum += static_cast<double>(s.kept);
    report.min_weight = std::min(report.min_weight, s.min_weight);
    report.max_negative_mass = std::max(report.max_negative_mass, s.negative_mass);
    report.max_dropped_mass = std::max(report.max_dropped_mass, s.dropped_mass);
    report.max_rest_correction = std::max(report.max_rest_correction, s.correction);
    negative_sum += s.negative_mass;
    dropped_sum += s.dropped_mass;
    report.negative_vertices += s.negative_mass > 0.0 ? 1 : 0;
    report.on_face += s.location == kernels::MvcLocation::on_face ? 1 : 0;
    report.on_vertex += s.location == kernels::MvcLocation::on_vertex ? 1 : 0;
  }
  const auto count = static_cast<double>(std::max<std::size_t>(stats.size(), 1));
  report.mean_negative_mass = negative_sum / count;
  report.mean_dropped_mass = dropped_sum / count;
  report.mean_rings_per_vertex = kept_sum / count;
  return report;
}

void pack_rows(const std::vector<std::vector<std::pair<std::uint32_t, double>>>& rows, CageWeights& csr) {
  csr.start.assign(1, 0);
  csr.column.clear();
  csr.weight.clear();
  for (const auto& row : rows) {
    for (const auto& [j, w] : row) {
      csr.column.push_back(j);
      csr.weight.push_back(w);
    }
    csr.start.push_back(static_cast<std::uint32_t>(csr.column.size()));
  }
}

// Per thread: a vertex's MVC weights and its rings' sums.
struct VertexScratch {
  std::vector<double> mvc, w, mass, weight;
  std::vector<Eigen::Vector3d> moment;
  std::vector<std::uint32_t> order;
  std::vector<std::uint8_t> is_kept;
  VertexScratch(std::size_t cage_vertices, std::size_t rings)
      : mvc(4 * cage_vertices),
        w(cage_vertices),
        mass(rings),
        weight(rings),
        moment(rings),
        order(rings),
        is_kept(rings) {}
};

// Binds the mesh's vertices to the cage: each vertex's mean value coordinates, the rings it keeps,
// the weight of the others folded onto them, its slots, statistics and, when wanted, CSR row.
struct VertexBinder {
  const CageModel& cage;
  const TriangleMesh& mesh;
  std::size_t at_least;
  double weight_left_out;
  Slots& slots;
  std::vector<VertexStats>& stats;
  std::vector<std::vector<std::pair<std::uint32_t, double>>>& rows;

  void run() const {
    // Weights in the binding pose, where the cage embeds the mesh without folds.
    const kernels::CageView view{cage.binding_vertices, cage.triangles};
    const kernels::CageFrame frame = kernels::cage_frame(cage.binding_vertices);
    parallel_blocks(mesh.vertices.size(), 64, [&](std::size_t first, std::size_t last) {
      VertexScratch x(cage.rest_vertices.size(), cage.ring_station.size());
      for (std::size_t v = first; v != last; ++v) bind_vertex(v, view, frame, x);
    });
  }

  void bind_vertex(std::size_t v, const kernels::CageView& view, const kernels::CageFrame& frame,
                   VertexScratch& x) const {
    const std::size_t rings = cage.ring_station.size();
    const std::size_t n = cage.rest_vertices.size();
    const kernels::MvcResult r = kernels::mean_value_coordinates(cage.mesh_binding[v], view, frame, x.mvc, x.w);
    std::fill(x.mass.begin(), x.mass.end(), 0.0);
    std::fill(x.weight.begin(), x.weight.end(), 0.0);
    std::fill(x.moment.begin(), x.moment.end(), Eigen::Vector3d::Zero());
    for (std::size_t j = 0; j < n; ++j) {
      const std::uint32_t g = cage.vertex_ring[j];
      x.mass[g] += std::abs(x.w[j]);
      x.weight[g] += x.w[j];
      x.moment[g] += x.w[j] * cage.offset[j];
    }
    const auto [keep, dropped] = choose_rings(x.mass, at_least, weight_left_out, x.order);
    if (keep < rings) fold_left_out(cage, std::span(x.order).first(keep), x.weight, x.moment, x.is_kept);
    double kept = 0.0;
    for (std::size_t k = 0; k < keep; ++k) kept += x.weight[x.order[k]];
    // Renormalized to a partition of unity, so a rigid translation of the rod stays exact (the
    // folded weights already sum to MVC's 1, but for rounding).
    const double scale = kept != 0.0 ? 1.0 / kept : 1.0;
    // Carried to the rings' rest poses, the kept weights put the vertex at Σ b_g c_g + R_g A_g; the
    // rest of the way (the bend between binding and rest pose, and what localization left out) is
    // shared by the kept rings in proportion to their weight, rotating with each ring: the rest
    // pose is then reproduced exactly and a rigid motion of the rod moves the vertex rigidly.
    Eigen::Vector3d reach = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < keep; ++k) {
      const kernels::RingPose& rp = cage.ring_rest[x.order[k]];
      reach += scale * (x.weight[x.order[k]] * rp.centre + rp.rotation * x.moment[x.order[k]]);
    }
    const Eigen::Vector3d correction = mesh.vertices[v] - reach;
    slots.ring[v].clear();
    slots.coef[v].clear();
    for (std::size_t k = 0; k < keep; ++k) {
      const std::uint32_t g = x.order[k];
      const double bg = scale * x.weight[g];
      const Eigen::Vector3d ag = scale * x.moment[g] + bg * (cage.ring_rest[g].rotation.transpose() * correction);
      slots.set(v, k, g, bg, ag);
    }
    stats[v] = {r.min_weight, r.negative_mass, dropped, correction.norm(), keep, r.location};
    if (rows.empty()) return;
    rows[v].clear();
    std::fill(x.is_kept.begin(), x.is_kept.end(), 0);
    for (std::size_t k = 0; k < keep; ++k) x.is_kept[x.order[k]] = 1;
    for (std::size_t j = 0; j < n; ++j)
      if (x.is_kept[cage.vertex_ring[j]] != 0 && x.w[j] != 0.0)
        rows[v].emplace_back(static_cast<std::uint32_t>(j), scale * x.w[j]);
  }
};

}  // namespace

SkinBinding bind_mean_value(const CageModel& cage, const TriangleMesh& mesh, int rings_per_vertex,
                            double weight_left_out, SkinReport& report, CageWeights* csr) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t rings = cage.ring_station.size();
  const std::size_t vertices = mesh.vertices.size();
  const std::size_t at_least =
      rings_per_vertex <= 0 ? rings : std::min(rings, static_cast<std::size_t>(rings_per_vertex));
  Slots slots;
  slots.resize(vertices);
  std::vector<VertexStats> stats(vertices);
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(csr != nullptr ? vertices : 0);
  const VertexBinder binder{cage, mesh, at_least, weight_left_out, slots, stats, rows};
  binder.run();
  report = skin_report_of(stats);
  report.method = rings_per_vertex <= 0 ? SkinningMethod::cage_full : SkinningMethod::cage;
  SkinBinding b = pack(mesh, slots, weight_left_out > 0.0 ? rings : at_least);
  report.rest_error = rest_error(b, mesh);
  report.slots_per_vertex = slots_per_vertex(b);
  if (csr != nullptr) pack_rows(rows, *csr);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

SkinBinding bind_linear_blend(const CageModel& cage, const TriangleMesh& mesh, SkinReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::uint32_t> joints;  // bead rings, in order along the rod
  for (std::size_t g = 0; g < cage.ring_bead.size(); ++g)
    if (cage.ring_bead[g] >= 0) joints.push_back(static_cast<std::uint32_t>(g));
  Slots slots;
  slots.resize(mesh.vertices.size());
  parallel_each(mesh.vertices.size(), [&](std::size_t v) {
    const Eigen::Vector3d& x = mesh.vertices[v];
    double best = std::numeric_limits<double>::infinity(), best_t = 0.0;
    std::size_t best_j = 0;
    for (std::size_t j = 0; j + 1 < joints.size(); ++j) {
      const Eigen::Vector3d a = cage.ring_rest[joints[j]].centre, c = cage.ring_rest[joints[j + 1]].centre;
      const Eigen::Vector3d d = c - a;
      const double t = std::clamp((x - a).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
      const double dist = (a + t * d - x).norm();
      if (dist < best) {
        best = dist;
        best_t = t;
        best_j = j;
      }
    }
    const std::uint32_t g[2] = {joints[best_j], joints[best_j + 1]};
    const double w[2] = {1.0 - best_t, best_t};
    for (std::size_t k = 0; k < 2; ++k) {
      const kernels::RingPose& r = cage.ring_rest[g[k]];
      slots.set(v, k, g[k], w[k], w[k] * (r.rotation.transpose() * (x - r.centre)));
    }
  });
  SkinBinding b = pack(mesh, slots, 2);
  report = SkinReport{};
  report.method = SkinningMethod::linear_blend;
  report.rings_per_vertex = 2;
  report.mean_rings_per_vertex = 2.0;
  report.slots_per_vertex = 2.0 * slots_per_vertex(b);  // two stations a lane, padding included
  report.rest_error = rest_error(b, mesh);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

namespace {

// A place s in ring index: g + f between rings g and g + 1 (ring order is arc order), clamped to
// the first and last ring.
double ring_parameter(std::span<const double> arc, double s) {
  const std::size_t n = arc.size();
  if (n < 2 || s <= arc.front()) return 0.0;
  if (s >= arc.back()) return static_cast<double>(n - 1);
  const auto g = static_cast<std::size_t>(std::upper_bound(arc.begin(), arc.end(), s) - arc.begin()) - 1;
  const double span = arc[g + 1] - arc[g];
  return static_cast<double>(g) + (span > 0.0 ? (s - arc[g]) / span : 0.0);
}

}  // namespace

void add_station_rings(CageModel& cage, kernels::RodPoses<const double> rest, std::span<const double> section_length) {
  const std::size_t sections = section_length.size();
  const std::size_t first = cage.ring_station.size();
  double arc = 0.0;
  for (std::uint32_t st = 0; st <= 2 * sections; ++st) {
    const std::size_t k = st / 2;
    const double at = (st & 1U) != 0 ? arc + 0.5 * section_length[k] : arc;
    if ((st & 1U) != 0) arc += section_length[k];
    cage.ring_station.push_back(st);
    cage.ring_binding.push_back({Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, at)});
    cage.ring_bead.push_back(-1);
  }
  cage.ring_rest.resize(cage.ring_station.size());
  kernels::ring_poses(rest, std::span<const std::uint32_t>(cage.ring_station).subspan(first),
                      std::span<kernels::RingPose>(cage.ring_rest).subspan(first));
  cage.first_station_ring = first;
}

SkinBinding bind_along_rod(const CageModel& cage, const TriangleMesh& mesh, SkinReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t first = cage.first_station_ring;
  const std::size_t rings = cage.ring_station.size() - first;
  std::vector<double> arc(rings);
  for (std::size_t g = 0; g < rings; ++g) arc[g] = cage.ring_binding[first + g].centre.z();
  std::vector<kernels::Screw> rest(rings - 1);  // the rest screw of each station pair
  for (std::size_t g = 0; g + 1 < rings; ++g)
    rest[g] = kernels::screw_between(cage.ring_rest[first + g], cage.ring_rest[first + g + 1]);
  Slots slots;
  slots.resize(mesh.vertices.size());
  parallel_each(mesh.vertices.size(), [&](std::size_t v) {
    // The pair either side of the place (past an end: the end pair at t = 0 or 1, the end
    // station's frame carried on rigidly).
    const double u = ring_parameter(arc, cage.mesh_place[v]);
    const std::size_t g = std::min(static_cast<std::size_t>(u), rings - 2);
    const double t = std::clamp(u - static_cast<double>(g), 0.0, 1.0);
    const kernels::RingPose at = kernels::screw_pose(rest[g], t);
    slots.set(v, 0, static_cast<std::uint32_t>(first + g), t, at.rotation.transpose() * (mesh.vertices[v] - at.centre));
  });
  SkinBinding b = pack(mesh, slots, 1);
  b.screw = true;
  report = SkinReport{};
  report.method = SkinningMethod::along_rod;
  report.rings_per_vertex = 2;  // the two stations of its pair
  report.mean_rings_per_vertex = 2.0;
  report.slots_per_vertex = 2.0 * slots_per_vertex(b);  // two stations a lane, padding included
  report.rest_error = rest_error(b, mesh);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

}  // namespace haustra::detail
