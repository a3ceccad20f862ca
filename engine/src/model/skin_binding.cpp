// Binding an organ mesh to its cage: mean value coordinates, localized to the rings of largest weight.
#include "model/skin_binding.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "haustra/kernels/mean_value_coordinates.hpp"
#include "step/scheduler.hpp"

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

// Packs vertices into blocks that share their ring set: vertices sorted by ring set (shorter sets
// first, then lexicographically, then by index), each set filling whole blocks, the last padded.
SkinBinding pack(const TriangleMesh& mesh, const Slots& slots) {
  const std::size_t n = mesh.vertices.size();
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0U);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    const auto &ra = slots.ring[a], &rb = slots.ring[b];
    if (ra.size() != rb.size()) return ra.size() < rb.size();
    return std::lexicographical_compare(ra.begin(), ra.end(), rb.begin(), rb.end());
  });
  SkinBinding b;
  b.vertices = n;
  b.slot_start.push_back(0);
  std::size_t i = 0;
  while (i < n) {
    const std::vector<std::uint32_t>& set = slots.ring[order[i]];
    std::size_t j = i;
    while (j < n && slots.ring[order[j]] == set) ++j;
    const std::size_t k = set.size();
    for (std::size_t first = i; first < j; first += kSkinLanes) {
      const std::size_t slot0 = b.ring.size();
      b.ring.insert(b.ring.end(), set.begin(), set.end());
      b.slot_start.push_back(static_cast<std::uint32_t>(b.ring.size()));
      b.coefficient.resize(b.ring.size() * kSkinCoefficients * kSkinLanes, 0.0f);
      for (std::size_t l = 0; l < kSkinLanes; ++l) {
        const bool real = first + l < j;
        const std::uint32_t v = real ? order[first + l] : kernels::kNoVertex;
        b.vertex.push_back(v);
        b.rest_x.push_back(real ? static_cast<float>(mesh.vertices[v].x()) : 0.0f);
        b.rest_y.push_back(real ? static_cast<float>(mesh.vertices[v].y()) : 0.0f);
        b.rest_z.push_back(real ? static_cast<float>(mesh.vertices[v].z()) : 0.0f);
        if (!real) continue;
        for (std::size_t s = 0; s < k; ++s)
          for (std::size_t c = 0; c < kSkinCoefficients; ++c)
            b.coefficient[((slot0 + s) * kSkinCoefficients + c) * kSkinLanes + l] =
                static_cast<float>(slots.coef[v][4 * s + c]);
      }
    }
    i = j;
  }
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

struct VertexStats {
  double min_weight = 0.0, negative_mass = 0.0, dropped_mass = 0.0, correction = 0.0;
  std::size_t kept = 0;
  kernels::MvcLocation location = kernels::MvcLocation::general;
};

// The rings of largest weight mass (ties: lower ring first): at least `at_least`, and more
// while the mass left out exceeds `weight_left_out` of the total; then in ring order.
// Returns how many rings `order` starts with and the weight mass the others carry.
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

// The binding's report from each vertex's statistics: the worst and the mean.
SkinReport skin_report_of(const std::vector<VertexStats>& stats) {
  SkinReport report;
  report.method = SkinningMethod::mean_value;
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

}  // namespace

SkinBinding bind_mean_value(const CageModel& cage, const TriangleMesh& mesh, int rings_per_vertex,
                            double weight_left_out, SkinReport& report, CageWeights* csr) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t rings = cage.ring_station.size();
  const std::size_t n = cage.rest_vertices.size();
  const std::size_t at_least =
      rings_per_vertex <= 0 ? rings : std::min(rings, static_cast<std::size_t>(rings_per_vertex));
  Slots slots;
  slots.resize(mesh.vertices.size());
  // Weights in the binding pose, where the cage embeds the mesh without folds.
  const kernels::CageView view{cage.binding_vertices, cage.triangles};
  const kernels::CageFrame frame = kernels::cage_frame(cage.binding_vertices);

  std::vector<VertexStats> stats(mesh.vertices.size());
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(csr != nullptr ? mesh.vertices.size() : 0);

  parallel_blocks(mesh.vertices.size(), 64, [&](std::size_t first, std::size_t last) {
    std::vector<double> scratch(4 * n), w(n), mass(rings), weight(rings);
    std::vector<Eigen::Vector3d> moment(rings);
    std::vector<std::uint32_t> order(rings);
    for (std::size_t v = first; v != last; ++v) {
      const kernels::MvcResult r = kernels::mean_value_coordinates(cage.mesh_binding[v], view, frame, scratch, w);
      std::fill(mass.begin(), mass.end(), 0.0);
      std::fill(weight.begin(), weight.end(), 0.0);
      std::fill(moment.begin(), moment.end(), Eigen::Vector3d::Zero());
      for (std::size_t j = 0; j < n; ++j) {
        const std::uint32_t g = cage.vertex_ring[j];
        mass[g] += std::abs(w[j]);
        weight[g] += w[j];
        moment[g] += w[j] * cage.offset[j];
      }
      const auto [keep, dropped] = choose_rings(mass, at_least, weight_left_out, order);
      double kept = 0.0;
      for (std::size_t k = 0; k < keep; ++k) kept += weight[order[k]];
      // Renormalized to a partition of unity, so a rigid translation of the rod stays exact.
      const double scale = kept != 0.0 ? 1.0 / kept : 1.0;
      // Carried to the rings' rest poses, the kept weights put the vertex at Σ b_g c_g + R_g A_g;
      // the rest of the way (the bend between binding and rest pose, and what localization left
      // out) is shared by the kept rings in proportion to their weight, rotating with each ring:
      // the rest pose is then reproduced exactly and a rigid motion of the rod moves the vertex
      // rigidly.
      Eigen::Vector3d reach = Eigen::Vector3d::Zero();
      for (std::size_t k = 0; k < keep; ++k) {
        const kernels::RingPose& rp = cage.ring_rest[order[k]];
        reach += scale * (weight[order[k]] * rp.centre + rp.rotation * moment[order[k]]);
      }
      const Eigen::Vector3d correction = mesh.vertices[v] - reach;
      for (std::size_t k = 0; k < keep; ++k) {
        const double bg = scale * weight[order[k]];
        const Eigen::Vector3d ag =
            scale * moment[order[k]] + bg * (cage.ring_rest[order[k]].rotation.transpose() * correction);
        slots.set(v, k, order[k], bg, ag);
      }
      stats[v] = {r.min_weight, r.negative_mass, dropped, correction.norm(), keep, r.location};
      if (csr != nullptr) {
        std::vector<std::uint8_t> kept_ring(rings, 0);
        for (std::size_t k = 0; k < keep; ++k) kept_ring[order[k]] = 1;
        for (std::size_t j = 0; j < n; ++j)
          if (kept_ring[cage.vertex_ring[j]] != 0 && w[j] != 0.0)
            rows[v].emplace_back(static_cast<std::uint32_t>(j), scale * w[j]);
      }
    }
  });

  report = skin_report_of(stats);
  SkinBinding b = pack(mesh, slots);
  report.rest_error = rest_error(b, mesh);
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
  SkinBinding b = pack(mesh, slots);
  report = SkinReport{};
  report.method = SkinningMethod::linear_blend;
  report.rings_per_vertex = 2;
  report.mean_rings_per_vertex = 2.0;
  report.rest_error = rest_error(b, mesh);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

}  // namespace haustra::detail
