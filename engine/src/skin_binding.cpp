#include "skin_binding.hpp"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "haustra/kernels/mean_value_coordinates.hpp"

namespace haustra::detail {
namespace {

using kernels::kSkinCoefficients;
using kernels::kSkinLanes;

SkinBinding empty_binding(const TriangleMesh& mesh, std::size_t slots) {
  SkinBinding b;
  b.vertices = mesh.vertices.size();
  b.slots = slots;
  const std::size_t blocks = (b.vertices + kSkinLanes - 1) / kSkinLanes;
  b.rest_x.assign(blocks * kSkinLanes, 0.0f);
  b.rest_y.assign(blocks * kSkinLanes, 0.0f);
  b.rest_z.assign(blocks * kSkinLanes, 0.0f);
  for (std::size_t v = 0; v < b.vertices; ++v) {
    b.rest_x[v] = static_cast<float>(mesh.vertices[v].x());
    b.rest_y[v] = static_cast<float>(mesh.vertices[v].y());
    b.rest_z[v] = static_cast<float>(mesh.vertices[v].z());
  }
  b.ring.assign(blocks * slots * kSkinLanes, 0);
  b.coefficient.assign(blocks * slots * kSkinCoefficients * kSkinLanes, 0.0f);
  return b;
}

void set_slot(SkinBinding& b, std::size_t v, std::size_t slot, std::uint32_t ring, double weight,
              const Eigen::Vector3d& moment) {
  const std::size_t block = v / kSkinLanes, lane = v % kSkinLanes;
  const std::size_t at = (block * b.slots + slot) * kSkinLanes + lane;
  const std::size_t c = (block * b.slots + slot) * kSkinCoefficients * kSkinLanes + lane;
  b.ring[at] = ring;
  b.coefficient[c] = static_cast<float>(weight);
  b.coefficient[c + kSkinLanes] = static_cast<float>(moment.x());
  b.coefficient[c + 2 * kSkinLanes] = static_cast<float>(moment.y());
  b.coefficient[c + 3 * kSkinLanes] = static_cast<float>(moment.z());
}

}  // namespace

SkinBinding bind_mean_value(const CageModel& cage, const TriangleMesh& mesh, int rings_per_vertex, SkinReport& report,
                            CageWeights* csr) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t rings = cage.ring_station.size();
  const std::size_t n = cage.rest_vertices.size();
  const std::size_t keep = rings_per_vertex <= 0 ? rings : std::min(rings, static_cast<std::size_t>(rings_per_vertex));
  SkinBinding b = empty_binding(mesh, keep);
  const kernels::CageView view{cage.rest_vertices, cage.triangles};
  const kernels::CageFrame frame = kernels::cage_frame(cage.rest_vertices);

  struct VertexStats {
    double min_weight = 0.0, negative_mass = 0.0, dropped_mass = 0.0;
    kernels::MvcLocation location = kernels::MvcLocation::general;
  };
  std::vector<VertexStats> stats(mesh.vertices.size());
  std::vector<std::vector<std::pair<std::uint32_t, double>>> rows(csr != nullptr ? mesh.vertices.size() : 0);

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertices.size(), 64), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<double> scratch(4 * n), w(n), mass(rings), weight(rings);
    std::vector<Eigen::Vector3d> moment(rings);
    std::vector<std::uint32_t> order(rings);
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      const kernels::MvcResult r = kernels::mean_value_coordinates(mesh.vertices[v], view, frame, scratch, w);
      std::fill(mass.begin(), mass.end(), 0.0);
      std::fill(weight.begin(), weight.end(), 0.0);
      std::fill(moment.begin(), moment.end(), Eigen::Vector3d::Zero());
      for (std::size_t j = 0; j < n; ++j) {
        const std::uint32_t g = cage.vertex_ring[j];
        mass[g] += std::abs(w[j]);
        weight[g] += w[j];
        moment[g] += w[j] * cage.offset[j];
      }
      // The `keep` rings of largest weight mass (ties: lower ring first), then in ring order.
      std::iota(order.begin(), order.end(), 0U);
      std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep), order.end(),
                        [&](std::uint32_t a, std::uint32_t c) { return mass[a] != mass[c] ? mass[a] > mass[c] : a < c; });
      std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep));
      double kept = 0.0, dropped = 0.0;
      for (std::size_t k = 0; k < keep; ++k) kept += weight[order[k]];
      for (std::size_t k = keep; k < rings; ++k) dropped += mass[order[k]];
      // Renormalized to a partition of unity, so a rigid translation of the rod stays exact.
      const double scale = kept != 0.0 ? 1.0 / kept : 1.0;
      for (std::size_t k = 0; k < keep; ++k) set_slot(b, v, k, order[k], scale * weight[order[k]], scale * moment[order[k]]);
      stats[v] = {r.min_weight, r.negative_mass, dropped, r.location};
      if (csr != nullptr) {
        std::vector<std::uint8_t> kept_ring(rings, 0);
        for (std::size_t k = 0; k < keep; ++k) kept_ring[order[k]] = 1;
        for (std::size_t j = 0; j < n; ++j)
          if (kept_ring[cage.vertex_ring[j]] != 0 && w[j] != 0.0)
            rows[v].emplace_back(static_cast<std::uint32_t>(j), scale * w[j]);
      }
    }
  });

  report = SkinReport{};
  report.method = SkinningMethod::mean_value;
  report.rings_per_vertex = keep;
  double negative_sum = 0.0, dropped_sum = 0.0;
  for (const VertexStats& s : stats) {
    report.min_weight = std::min(report.min_weight, s.min_weight);
    report.max_negative_mass = std::max(report.max_negative_mass, s.negative_mass);
    report.max_dropped_mass = std::max(report.max_dropped_mass, s.dropped_mass);
    negative_sum += s.negative_mass;
    dropped_sum += s.dropped_mass;
    report.negative_vertices += s.negative_mass > 0.0 ? 1 : 0;
    report.on_face += s.location == kernels::MvcLocation::on_face ? 1 : 0;
    report.on_vertex += s.location == kernels::MvcLocation::on_vertex ? 1 : 0;
  }
  const auto count = static_cast<double>(std::max<std::size_t>(stats.size(), 1));
  report.mean_negative_mass = negative_sum / count;
  report.mean_dropped_mass = dropped_sum / count;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d rest(b.rest_x[v], b.rest_y[v], b.rest_z[v]);
    report.rest_error = std::max(report.rest_error, (rest - mesh.vertices[v]).norm());
  }
  if (csr != nullptr) {
    csr->start.assign(1, 0);
    csr->column.clear();
    csr->weight.clear();
    for (const auto& row : rows) {
      for (const auto& [j, w] : row) {
        csr->column.push_back(j);
        csr->weight.push_back(w);
      }
      csr->start.push_back(static_cast<std::uint32_t>(csr->column.size()));
    }
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

SkinBinding bind_linear_blend(const CageModel& cage, const TriangleMesh& mesh, SkinReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::uint32_t> joints;  // bead rings, in order along the rod
  for (std::size_t g = 0; g < cage.ring_bead.size(); ++g)
    if (cage.ring_bead[g] >= 0) joints.push_back(static_cast<std::uint32_t>(g));
  SkinBinding b = empty_binding(mesh, 2);
  tbb::parallel_for(std::size_t{0}, mesh.vertices.size(), [&](std::size_t v) {
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
      set_slot(b, v, k, g[k], w[k], w[k] * (r.rotation.transpose() * (x - r.centre)));
    }
  });
  report = SkinReport{};
  report.method = SkinningMethod::linear_blend;
  report.rings_per_vertex = 2;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d rest(b.rest_x[v], b.rest_y[v], b.rest_z[v]);
    report.rest_error = std::max(report.rest_error, (rest - mesh.vertices[v]).norm());
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return b;
}

double localized_rest_error(const SkinBinding& b, const CageModel& cage, const TriangleMesh& mesh) {
  double worst = 0.0;
  for (std::size_t v = 0; v < b.vertices; ++v) {
    const std::size_t block = v / kSkinLanes, lane = v % kSkinLanes;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    for (std::size_t s = 0; s < b.slots; ++s) {
      const std::size_t at = (block * b.slots + s) * kSkinLanes + lane;
      const std::size_t c = (block * b.slots + s) * kSkinCoefficients * kSkinLanes + lane;
      const kernels::RingPose& r = cage.ring_rest[b.ring[at]];
      const Eigen::Vector3d a(b.coefficient[c + kSkinLanes], b.coefficient[c + 2 * kSkinLanes], b.coefficient[c + 3 * kSkinLanes]);
      x += static_cast<double>(b.coefficient[c]) * r.centre + r.rotation * a;
    }
    worst = std::max(worst, (x - mesh.vertices[v]).norm());
  }
  return worst;
}

}  // namespace haustra::detail
