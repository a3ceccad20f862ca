#include "cage_builder.hpp"

#include <fmt/format.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <cstdlib>
#include <map>
#include <set>

#include "embree_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/rod_curve.hpp"

namespace haustra::detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// A ring vertex on the inner side of a bend stops at this fraction of the distance at which its
// ray would cross a neighbouring ring's plane: the quads between them then never fold over.
constexpr double kBendHold = 0.97;
// Relaxation sweeps of the ring normals at kinks.
constexpr int kRelaxations = 200;
// No ring vertex goes beyond this many template (bead) radii: a cage that would need more does not
// fit the mesh (and would bind far-away tissue).
constexpr double kMaxGrowth = 3.0;

struct Ring {
  std::uint32_t station = 0;
  int bead = -1;                 // local bead index, −1 for a middle ring
  std::size_t after_bead = 0;    // a middle ring sits between bead after_bead and after_bead + 1
  double template_radius = 0.0;
  double arc = 0.0;              // rest arc length of its station
  kernels::RingPose pose;        // the station's frame: what carries the ring
  // The ring's plane: normal along the rod's chord across ±2 template radii (the tangent itself on
  // a circular arc; on a kinked centreline, neighbouring rings stay nearly parallel and the cage
  // does not fold), and the in-plane axes closest to the station's d1, d2.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(), e1 = Eigen::Vector3d::UnitX(), e2 = Eigen::Vector3d::UnitY();
};

struct Shape {
  std::vector<Ring> rings;
  std::size_t m = 0;
  std::vector<double> radius;     // rings × m
  std::vector<double> max_radius; // rings × m: the bend hold
  double cap_start = 0.0, cap_end = 0.0;  // axial reach of the two cap vertices beyond their rings
};

std::vector<double> node_arcs(std::span<const double> h) {
  std::vector<double> arc(h.size() + 1, 0.0);
  for (std::size_t k = 0; k < h.size(); ++k) arc[k + 1] = arc[k] + h[k];
  return arc;
}

kernels::RingPose station_pose(const CageBuildInput& in, std::uint32_t station) {
  const std::uint32_t stations[1] = {station};
  kernels::RingPose pose[1];
  kernels::ring_poses(in.rest, stations, pose);
  return pose[0];
}

double station_curvature(const CageBuildInput& in, std::uint32_t station) {
  const std::size_t k = station / 2;
  auto kappa = [&](std::size_t node) { return std::hypot(in.rest_strain[4 * node], in.rest_strain[4 * node + 1]); };
  return (station & 1U) != 0 ? 0.5 * (kappa(k) + kappa(k + 1)) : kappa(k);
}

void set_normal(Ring& r, const Eigen::Vector3d& normal) {
  r.normal = normal;
  Eigen::Vector3d e1 = r.pose.rotation.col(0) - r.pose.rotation.col(0).dot(r.normal) * r.normal;
  if (!(e1.norm() > 1e-6)) e1 = r.pose.rotation.col(1) - r.pose.rotation.col(1).dot(r.normal) * r.normal;
  r.e1 = e1.normalized();
  r.e2 = r.normal.cross(r.e1);
}

void orient(const RodCurve& curve, Ring& r) {
  const double w = 2.0 * r.template_radius;
  Eigen::Vector3d chord = curve.pose_at(r.arc + w).position - curve.pose_at(r.arc - w).position;
  if (!(chord.norm() > 1e-9 * w)) chord = r.pose.rotation.col(2);
  Eigen::Vector3d normal = chord.normalized();
  if (normal.dot(r.pose.rotation.col(2)) < 0.5) normal = r.pose.rotation.col(2);  // a U-turn inside the window
  set_normal(r, normal);
}

std::vector<Ring> place_rings(const CageBuildInput& in, const std::set<std::uint32_t>& dropped) {
  const std::vector<double> arc = node_arcs(in.section_length);
  const RodCurve curve(in.section_length, in.rest_strain,
                       kernels::Pose{in.rest.node_rotation.get(0), in.rest.node_position.get(0)});
  std::vector<Ring> rings;
  for (std::size_t b = 0; b < in.bead_node.size(); ++b) {
    Ring r;
    r.station = static_cast<std::uint32_t>(2 * in.bead_node[b]);
    r.bead = static_cast<int>(b);
    r.template_radius = in.bead_radius[b];
    r.arc = arc[in.bead_node[b]];
    r.pose = station_pose(in, r.station);
    if (!dropped.contains(r.station)) rings.push_back(r);
    if (!in.desc.middle_rings || b + 1 == in.bead_node.size()) continue;
    // The station (node or section midpoint) nearest halfway in arc length, strictly between.
    const std::size_t ka = in.bead_node[b], kb = in.bead_node[b + 1];
    const double target = 0.5 * (arc[ka] + arc[kb]);
    std::uint32_t best = static_cast<std::uint32_t>(2 * ka + 1);
    double best_gap = kInf;
    for (std::size_t st = 2 * ka + 1; st < 2 * kb; ++st) {
      const double s = (st & 1U) != 0 ? arc[st / 2] + 0.5 * in.section_length[st / 2] : arc[st / 2];
      if (std::abs(s - target) < best_gap) {
        best_gap = std::abs(s - target);
        best = static_cast<std::uint32_t>(st);
      }
    }
    Ring mid;
    mid.station = best;
    mid.after_bead = b;
    mid.template_radius = 0.5 * (in.bead_radius[b] + in.bead_radius[b + 1]);
    mid.arc = (best & 1U) != 0 ? arc[best / 2] + 0.5 * in.section_length[best / 2] : arc[best / 2];
    mid.pose = station_pose(in, best);
    if (!dropped.contains(mid.station)) rings.push_back(mid);
  }
  for (Ring& r : rings) orient(curve, r);
  return rings;
}

Eigen::Vector3d ring_direction(const Ring& r, std::size_t i, std::size_t m) {
  const double theta = 2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(m);
  return r.e1 * std::cos(theta) + r.e2 * std::sin(theta);
}

// Where a ray from ring g's centre along e crosses the plane of ring h (if it does, going out).
double plane_crossing(const Ring& g, const Ring& h, const Eigen::Vector3d& e) {
  const Eigen::Vector3d n = h.normal;
  const double num = (h.pose.centre - g.pose.centre).dot(n);
  const double den = e.dot(n);
  return num * den > 0.0 ? num / den : kInf;
}

void assemble(const Shape& shape, CageModel& cage) {
  const std::size_t m = shape.m, rings = shape.rings.size();
  cage.ring_station.clear();
  cage.ring_rest.clear();
  cage.ring_bead.clear();
  cage.vertex_ring.clear();
  cage.offset.clear();
  cage.rest_vertices.clear();
  cage.triangles.clear();
  for (std::size_t g = 0; g < rings; ++g) {
    const Ring& r = shape.rings[g];
    cage.ring_station.push_back(r.station);
    cage.ring_rest.push_back(r.pose);
    cage.ring_bead.push_back(r.bead);
    for (std::size_t i = 0; i < m; ++i) {
      const Eigen::Vector3d o = r.pose.rotation.transpose() * (shape.radius[g * m + i] * ring_direction(r, i, m));
      cage.vertex_ring.push_back(static_cast<std::uint32_t>(g));
      cage.offset.push_back(o);
      cage.rest_vertices.push_back(r.pose.centre + r.pose.rotation * o);
    }
  }
  const auto caps = static_cast<std::uint32_t>(cage.offset.size());
  const std::size_t cap_rings[2] = {0, rings - 1};
  for (int c = 0; c < 2; ++c) {
    const Ring& r = shape.rings[cap_rings[c]];
    const Eigen::Vector3d cap_offsets[2] = {r.pose.rotation.transpose() * (-shape.cap_start * r.normal),
                                            r.pose.rotation.transpose() * (shape.cap_end * r.normal)};
    cage.vertex_ring.push_back(static_cast<std::uint32_t>(cap_rings[c]));
    cage.offset.push_back(cap_offsets[c]);
    cage.rest_vertices.push_back(r.pose.centre + r.pose.rotation * cap_offsets[c]);
  }
  auto id = [&](std::size_t g, std::size_t i) { return static_cast<std::uint32_t>(g * m + i % m); };
  // Outward with (d1, d2, d3) right-handed: (g, i) → (g, i+1) → (g+1, i).
  for (std::size_t g = 0; g + 1 < rings; ++g)
    for (std::size_t i = 0; i < m; ++i) {
      cage.triangles.push_back({id(g, i), id(g, i + 1), id(g + 1, i)});
      cage.triangles.push_back({id(g + 1, i), id(g, i + 1), id(g + 1, i + 1)});
    }
  for (std::size_t i = 0; i < m; ++i) {
    cage.triangles.push_back({caps, id(0, i + 1), id(0, i)});
    cage.triangles.push_back({caps + 1, id(rings - 1, i), id(rings - 1, i + 1)});
  }
}

struct Problems {
  std::vector<std::uint32_t> outside;                            // mesh vertices
  std::vector<std::pair<std::uint32_t, unsigned>> crossing;      // (mesh vertex of the edge, cage triangle)
  std::vector<std::pair<std::uint32_t, unsigned>> self;          // (cage vertex of the edge, cage triangle)
  [[nodiscard]] bool none() const { return outside.empty() && crossing.empty() && self.empty(); }
};

std::vector<std::array<std::uint32_t, 2>> unique_edges(std::span<const std::array<std::uint32_t, 3>> triangles) {
  std::vector<std::array<std::uint32_t, 2>> edges;
  edges.reserve(3 * triangles.size());
  for (const auto& t : triangles)
    for (int i = 0; i < 3; ++i) {
      const std::uint32_t a = t[static_cast<std::size_t>(i)], b = t[static_cast<std::size_t>((i + 1) % 3)];
      edges.push_back({std::min(a, b), std::max(a, b)});
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

// Every hit of the segment a→b on the scene, except triangles for which `skip` says so.
template <class Skip>
bool segment_hits(const EmbreeScene& scene, const Eigen::Vector3d& a, const Eigen::Vector3d& b, Skip skip,
                  unsigned& triangle) {
  const Eigen::Vector3d d = b - a;
  const double len = d.norm();
  if (!(len > 0.0)) return false;
  const double step = 64.0 * std::numeric_limits<float>::epsilon() * (1.0 + a.cwiseAbs().maxCoeff()) / len;
  double t = step;
  for (int guard = 0; guard < 256; ++guard) {
    const EmbreeScene::Hit h = scene.first_hit(a, d, t, 1.0 - step);
    if (!h.found) return false;
    if (!skip(h.triangle)) {
      triangle = h.triangle;
      return true;
    }
    t = h.distance + step;
  }
  return false;
}

Problems find_problems(const CageModel& cage, const TriangleMesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& mesh_edges,
                       bool check_self) {
  EmbreeScene scene;
  scene.add_triangles(cage.rest_vertices, cage.triangles);
  scene.commit();
  Problems p;
  std::vector<std::uint8_t> outside(mesh.vertices.size(), 0);
  tbb::parallel_for(std::size_t{0}, mesh.vertices.size(), [&](std::size_t v) {
    outside[v] = scene.inside(mesh.vertices[v]) ? 0 : 1;
  });
  for (std::size_t v = 0; v < outside.size(); ++v)
    if (outside[v] != 0) p.outside.push_back(static_cast<std::uint32_t>(v));
  if (p.outside.empty()) {
    std::vector<std::int64_t> hit(mesh_edges.size(), -1);
    tbb::parallel_for(std::size_t{0}, mesh_edges.size(), [&](std::size_t e) {
      unsigned tri = 0;
      if (segment_hits(scene, mesh.vertices[mesh_edges[e][0]], mesh.vertices[mesh_edges[e][1]],
                       [](unsigned) { return false; }, tri))
        hit[e] = tri;
    });
    for (std::size_t e = 0; e < hit.size(); ++e)
      if (hit[e] >= 0) p.crossing.emplace_back(mesh_edges[e][0], static_cast<unsigned>(hit[e]));
  }
  if (check_self) {
    for (const auto& e : unique_edges(cage.triangles)) {
      unsigned tri = 0;
      auto incident = [&](unsigned t) {
        const auto& c = cage.triangles[t];
        return std::find(c.begin(), c.end(), e[0]) != c.end() || std::find(c.begin(), c.end(), e[1]) != c.end();
      };
      if (segment_hits(scene, cage.rest_vertices[e[0]], cage.rest_vertices[e[1]], incident, tri))
        p.self.emplace_back(e[0], tri);
    }
  }
  return p;
}

std::string ring_name(const Ring& r, std::size_t g) {
  const std::size_t k = r.station / 2;
  const std::string at = (r.station & 1U) != 0 ? fmt::format("the middle of section {}", k) : fmt::format("node {}", k);
  if (r.bead >= 0)
    return fmt::format("ring {} (bead {} at {}, {:.3f} m along the rod)", g, r.bead, at, r.arc);
  return fmt::format("ring {} (middle ring at {}, {:.3f} m along the rod)", g, at, r.arc);
}

}  // namespace

CageModel build_cage(const CageBuildInput& in, CageReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  const CageDesc& d = in.desc;
  if (d.ring_vertices < 3 || d.ring_vertices > 64)
    throw FieldError(ErrorCode::invalid_argument, in.where + ".cage.ring_vertices",
                     fmt::format("expected 3 to 64 vertices per ring, got {}", d.ring_vertices));
  if (d.max_iterations < 1 || d.max_iterations > 1000)
    throw FieldError(ErrorCode::invalid_argument, in.where + ".cage.max_iterations",
                     fmt::format("expected 1 to 1000 inflation passes, got {}", d.max_iterations));
  if (in.bead_node.size() < 2)
    throw FieldError(ErrorCode::invalid_argument, in.where,
                     "a cage is built from the beads: give the segment at least two beads ([segment.beads])");
  const TriangleMesh& mesh = *in.mesh;
  const auto m = static_cast<std::size_t>(d.ring_vertices);
  const std::vector<std::array<std::uint32_t, 2>> mesh_edges = unique_edges(mesh.triangles);

  // Every mesh vertex should lie within a few radii of the rod: otherwise the mesh is somewhere
  // else (other units, another pose) and no cage can be grown around it.
  double largest_radius = 0.0;
  for (double r : in.bead_radius) largest_radius = std::max(largest_radius, r);
  {
    std::vector<Eigen::Vector3d> axis;
    for (std::size_t k = 0; k < in.rest.node_count(); ++k) axis.push_back(in.rest.node_position.get(k));
    double worst = 0.0;
    std::size_t worst_vertex = 0;
    for (std::size_t v = 0; v < mesh.vertices.size(); v += std::max<std::size_t>(1, mesh.vertices.size() / 2000)) {
      double best = kInf;
      for (const auto& a : axis) best = std::min(best, (mesh.vertices[v] - a).norm());
      if (best > worst) {
        worst = best;
        worst_vertex = v;
      }
    }
    if (worst > 6.0 * largest_radius + 0.01)
      throw FieldError(ErrorCode::invalid_geometry, in.where,
                       fmt::format("mesh vertex {} lies {:.4g} m from the nearest node of the rod, more than six bead radii "
                                   "({:.4g} m): is the mesh around the segment's rest centreline, in metres (scale), in "
                                   "the same place (translate)?",
                                   worst_vertex, worst, largest_radius));
  }

  std::set<std::uint32_t> dropped;  // stations whose ring was taken out of the cage
  CageModel cage;
  Problems final_check;
  for (;;) {
    Shape shape;
    shape.m = m;
    shape.rings = place_rings(in, dropped);
    const std::size_t rings = shape.rings.size();
    shape.radius.assign(rings * m, 0.0);
    shape.max_radius.assign(rings * m, kInf);
    EmbreeScene wall;
    wall.add_triangles(mesh.vertices, mesh.triangles);
    wall.commit();
    // How far the mesh reaches past each end ring along the rod's end tangent (only the part of
    // the mesh around that end: the rest of a curled organ may lie anywhere ahead).
    double start_reach = 0.0, end_reach = 0.0;
    for (const auto& v : mesh.vertices) {
      for (int end = 0; end < 2; ++end) {
        const Ring& r = end == 0 ? shape.rings.front() : shape.rings.back();
        const Eigen::Vector3d rel = v - r.pose.centre;
        const double along = (end == 0 ? -1.0 : 1.0) * rel.dot(r.normal);
        const double across = (rel - rel.dot(r.normal) * r.normal).norm();
        if (along > 0.0 && across < 2.0 * r.template_radius && along < 2.0 * r.template_radius)
          (end == 0 ? start_reach : end_reach) = std::max(end == 0 ? start_reach : end_reach, along);
      }
    }
    shape.cap_start = start_reach + in.clearance;
    shape.cap_end = end_reach + in.clearance;
    // Ring planes: relax the normals of rings whose wall would reach past a neighbour's plane
    // (a kink of the centreline sharper than the tube), towards their neighbours', until every
    // ring reaches its wall without folding or the relaxation stops helping.
    auto wall_radius = [&](const Ring& r, const Eigen::Vector3d& e) {
      const EmbreeScene::Hit h = wall.first_hit(r.pose.centre, e, 0.0, 4.0 * r.template_radius);
      return h.found ? h.distance + in.clearance : r.template_radius;
    };
    auto hold_of = [&](std::size_t g, const Eigen::Vector3d& e) {
      double hold = kInf;
      if (g > 0) hold = std::min(hold, plane_crossing(shape.rings[g], shape.rings[g - 1], e));
      if (g + 1 < rings) hold = std::min(hold, plane_crossing(shape.rings[g], shape.rings[g + 1], e));
      return kBendHold * hold;
    };
    for (int relax = 0; relax < kRelaxations; ++relax) {
      std::vector<std::uint8_t> stressed(rings, 0);
      for (std::size_t g = 0; g < rings; ++g)
        for (std::size_t i = 0; i < m; ++i) {
          const Eigen::Vector3d e = ring_direction(shape.rings[g], i, m);
          if (wall_radius(shape.rings[g], e) > hold_of(g, e)) {
            for (std::size_t h = g > 0 ? g - 1 : 0; h <= std::min(g + 1, rings - 1); ++h) stressed[h] = 1;
          }
        }
      if (std::find(stressed.begin(), stressed.end(), 1) == stressed.end()) break;
      std::vector<Eigen::Vector3d> smoothed(rings);
      for (std::size_t g = 0; g < rings; ++g) {
        smoothed[g] = shape.rings[g].normal;
        if (stressed[g] == 0 || g == 0 || g + 1 == rings) continue;
        smoothed[g] = (shape.rings[g - 1].normal + 2.0 * shape.rings[g].normal + shape.rings[g + 1].normal).normalized();
      }
      for (std::size_t g = 0; g < rings; ++g) set_normal(shape.rings[g], smoothed[g]);
    }
    report.held_at_bends = 0;
    for (std::size_t g = 0; g < rings; ++g) {
      const Ring& r = shape.rings[g];
      for (std::size_t i = 0; i < m; ++i) {
        const Eigen::Vector3d e = ring_direction(r, i, m);
        shape.max_radius[g * m + i] = hold_of(g, e);
        // Start at the wall: the first hit of the ray from the centre, plus the clearance.
        shape.radius[g * m + i] = std::min(wall_radius(r, e), shape.max_radius[g * m + i]);
      }
    }

    // Inflation: push the cage triangles nearest to every stray mesh vertex outward.
    Problems problems;
    int pass = 0;
    for (; pass < d.max_iterations; ++pass) {
      assemble(shape, cage);
      problems = find_problems(cage, mesh, mesh_edges, false);
      if (std::getenv("HAUSTRA_CAGE_DEBUG") != nullptr) {
        double rmax = 0; for (double r : shape.radius) rmax = std::max(rmax, r);
        fmt::print(stderr, "pass {}: {} outside, {} crossing, max radius {:.4f}, caps {:.4f} {:.4f}\n", pass, problems.outside.size(), problems.crossing.size(), rmax, shape.cap_start, shape.cap_end);
      }
      if (problems.outside.empty() && problems.crossing.empty()) break;
      EmbreeScene cage_scene;
      cage_scene.add_triangles(cage.rest_vertices, cage.triangles);
      cage_scene.commit();
      if (std::getenv("HAUSTRA_CAGE_DEBUG") != nullptr && pass == 6) {
        int held = 0, capped = 0, free_ = 0, weak = 0;
        for (std::uint32_t v : problems.outside) {
          const auto h = cage_scene.closest(mesh.vertices[v], kInf);
          const auto& tri = cage.triangles[h.triangle];
          for (std::uint32_t j : tri) {
            if (j >= rings * m) { ++free_; continue; }
            const double cap = kMaxGrowth * shape.rings[j / m].template_radius;
            if (shape.radius[j] >= shape.max_radius[j]) ++held; else if (shape.radius[j] >= cap) ++capped; else ++free_;
          }
          (void)weak;
        }
        fmt::print(stderr, "stuck triangle vertices: held {} capped {} free {}\n", held, capped, free_);
      }
      if (std::getenv("HAUSTRA_CAGE_DEBUG") != nullptr && pass == 0) {
        std::vector<double> dist;
        for (std::uint32_t v : problems.outside) dist.push_back(cage_scene.closest(mesh.vertices[v], kInf).distance);
        std::sort(dist.begin(), dist.end());
        fmt::print(stderr, "outside distances: median {:.4f} p90 {:.4f} max {:.4f}\n", dist[dist.size()/2], dist[dist.size()*9/10], dist.back());
        FILE* f = std::fopen("/tmp/cage0.obj", "w");
        for (const auto& v : cage.rest_vertices) fmt::print(f, "v {} {} {}\n", v.x(), v.y(), v.z());
        for (const auto& t : cage.triangles) fmt::print(f, "f {} {} {}\n", t[0]+1, t[1]+1, t[2]+1);
        std::fclose(f);
        f = std::fopen("/tmp/outside.xyz", "w");
        for (std::uint32_t v : problems.outside) fmt::print(f, "{} {} {}\n", mesh.vertices[v].x(), mesh.vertices[v].y(), mesh.vertices[v].z());
        std::fclose(f);
      }
      // Each cage vertex moves along its own direction (radial, or axial for a cap), by what it
      // takes to carry the nearest triangle past the stray point, in proportion to how much its
      // direction points at the point.
      std::vector<double> need(cage.offset.size(), 0.0);
      for (std::uint32_t v : problems.outside) {
        const Eigen::Vector3d& p = mesh.vertices[v];
        const EmbreeScene::Hit h = cage_scene.closest(p, kInf);
        if (!h.found) continue;
        const auto& tri = cage.triangles[h.triangle];
        const Eigen::Vector3d q = kernels::closest_point_on_triangle(p, cage.rest_vertices[tri[0]],
                                                                     cage.rest_vertices[tri[1]], cage.rest_vertices[tri[2]]);
        Eigen::Vector3d away = p - q;
        if (!(away.norm() > 1e-12))
          away = (cage.rest_vertices[tri[1]] - cage.rest_vertices[tri[0]]).cross(cage.rest_vertices[tri[2]] - cage.rest_vertices[tri[0]]);
        away.normalize();
        for (std::uint32_t j : tri) {
          const Ring& r = shape.rings[cage.vertex_ring[j]];
          const Eigen::Vector3d dir = j < rings * m ? ring_direction(r, j % m, m)
                                                    : Eigen::Vector3d((j == rings * m ? -1.0 : 1.0) * r.normal);
          const double c = dir.dot(away);
          if (c > 0.1) need[j] = std::max(need[j], std::min((h.distance + in.clearance) / c, r.template_radius));
        }
      }
      for (const auto& [v, tri] : problems.crossing)
        for (std::uint32_t j : cage.triangles[tri]) need[j] = std::max(need[j], in.clearance);
      bool moved = false;
      for (std::size_t j = 0; j < rings * m; ++j) {
        if (need[j] <= 0.0) continue;
        const double grown = std::min({shape.radius[j] + need[j], shape.max_radius[j], kMaxGrowth * shape.rings[j / m].template_radius});
        moved = moved || grown > shape.radius[j];
        shape.radius[j] = grown;
      }
      if (need[rings * m] > 0.0) {
        shape.cap_start += need[rings * m];
        moved = true;
      }
      if (need[rings * m + 1] > 0.0) {
        shape.cap_end += need[rings * m + 1];
        moved = true;
      }
      if (!moved) break;  // every push is held back by a bend
    }
    assemble(shape, cage);
    problems = find_problems(cage, mesh, mesh_edges, true);
    report.iterations = pass + 1;
    for (std::size_t j = 0; j < rings * m; ++j)
      if (shape.radius[j] >= shape.max_radius[j]) ++report.held_at_bends;

    // Cage triangles of two parts of the organ far apart along the rod may overlap where loops of
    // the organ touch (they do in the CT colon): the cage is then the union of its parts, which
    // the winding-number test and MVC both handle. A fold between rings near each other along the
    // rod is a defect to repair.
    const double local = 4.0 * largest_radius;
    std::vector<std::pair<std::size_t, std::size_t>> folds;
    std::size_t touching = 0;
    for (const auto& [v, tri] : problems.self) {
      const std::size_t a = cage.vertex_ring[v], b = cage.vertex_ring[cage.triangles[tri][0]];
      if (std::abs(shape.rings[a].arc - shape.rings[b].arc) <= local)
        folds.emplace_back(std::min(a, b), std::max(a, b));
      else
        ++touching;
    }
    std::size_t blamed = rings;
    std::vector<std::size_t> candidates;
    std::string what;
    if (!folds.empty()) {
      const auto [a, b] = folds.front();
      blamed = a;
      for (std::size_t g = a; g <= b; ++g) candidates.push_back(g);
      what = fmt::format("its cage folds over the cage of ring {}", b);
    } else if (!problems.crossing.empty() || !problems.outside.empty()) {
      EmbreeScene cage_scene;
      cage_scene.add_triangles(cage.rest_vertices, cage.triangles);
      cage_scene.commit();
      if (!problems.crossing.empty()) {
        blamed = cage.vertex_ring[cage.triangles[problems.crossing.front().second][0]];
        what = fmt::format("{} mesh edges cross the cage", problems.crossing.size());
      } else {
        const EmbreeScene::Hit h = cage_scene.closest(mesh.vertices[problems.outside.front()], kInf);
        blamed = h.found ? cage.vertex_ring[cage.triangles[h.triangle][0]] : 0;
        what = fmt::format("{} mesh vertices stay outside the cage (vertex {} among them)", problems.outside.size(),
                           problems.outside.front());
      }
      for (std::size_t g : {blamed, blamed + 1, blamed > 0 ? blamed - 1 : rings})
        if (g < rings) candidates.push_back(g);
    }
    if (blamed == rings) {  // embedded, free of folds
      final_check = std::move(problems);
      report.touching_loops = touching;
      break;
    }
    // Repair: take a ring out of the cage (its bead still collides): a middle ring first, the one
    // nearest the middle of the trouble; never an end ring; at most a third of the rings.
    std::size_t drop = rings;
    const double centre = 0.5 * (shape.rings[candidates.front()].arc + shape.rings[candidates.back()].arc);
    for (int pass_kind = 0; pass_kind < 2 && drop == rings; ++pass_kind)
      for (std::size_t g : candidates) {
        if (g == 0 || g + 1 == rings || (pass_kind == 0 && shape.rings[g].bead >= 0)) continue;
        if (drop == rings || std::abs(shape.rings[g].arc - centre) < std::abs(shape.rings[drop].arc - centre)) drop = g;
      }
    if (drop < rings && 3 * (dropped.size() + 1) <= place_rings(in, {}).size()) {
      dropped.insert(shape.rings[drop].station);
      continue;
    }
    const Ring& r = shape.rings[blamed];
    const double kappa = station_curvature(in, r.station);
    double reach = 0.0;
    for (std::size_t i = 0; i < m; ++i) reach = std::max(reach, shape.radius[blamed * m + i]);
    throw FieldError(
        ErrorCode::invalid_geometry, in.where,
        fmt::format("the cage cannot embed the mesh at {}: {}; the rod bends there with radius {} while the cage "
                    "reaches {:.1f} mm from it (after {} inflation passes, {} rings taken out). Fewer or smaller "
                    "beads there, a smaller cage.clearance or a smoother centreline may help.",
                    ring_name(r, blamed), what, kappa > 0.0 ? fmt::format("{:.1f} mm", 1e3 / kappa) : "infinite",
                    1e3 * reach, report.iterations, dropped.size()));
  }

  // The report.
  const std::size_t rings = cage.ring_station.size();
  report.rings = rings;
  report.bead_rings = static_cast<std::size_t>(std::count_if(cage.ring_bead.begin(), cage.ring_bead.end(), [](int b) { return b >= 0; }));
  report.middle_rings = rings - report.bead_rings;
  report.dropped_rings = dropped.size();
  report.ring_vertices = m;
  report.vertices = cage.offset.size();
  report.triangles = cage.triangles.size();
  report.clearance = in.clearance;
  report.inflation_min = kInf;
  report.inflation_max = -kInf;
  double sum = 0.0;
  report.tightest_bend = kInf;
  for (std::size_t g = 0; g < rings; ++g) {
    const int bead = cage.ring_bead[g];
    double tmpl = 0.0;
    if (bead >= 0) {
      tmpl = in.bead_radius[static_cast<std::size_t>(bead)];
    } else {
      // The middle ring's template: the mean of its neighbours' beads.
      const int before = cage.ring_bead[g - 1];
      tmpl = 0.5 * (in.bead_radius[static_cast<std::size_t>(before)] + in.bead_radius[static_cast<std::size_t>(before) + 1]);
    }
    for (std::size_t i = 0; i < m; ++i) {
      const double grow = cage.offset[g * m + i].norm() - tmpl;
      report.inflation_min = std::min(report.inflation_min, grow);
      report.inflation_max = std::max(report.inflation_max, grow);
      sum += grow;
    }
    const double kappa = station_curvature(in, cage.ring_station[g]);
    if (kappa > 0.0) report.tightest_bend = std::min(report.tightest_bend, 1.0 / kappa);
  }
  report.inflation_mean = sum / static_cast<double>(rings * m);
  report.mesh_vertices_outside = final_check.outside.size();
  report.crossing_edges = final_check.crossing.size();
  report.self_intersections = final_check.self.size() - report.touching_loops;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return cage;
}

}  // namespace haustra::detail
