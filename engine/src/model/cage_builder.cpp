// The cage around an organ mesh: rings on the beads and between them, grown until the mesh is inside
// (decision 0017).
#include "model/cage_builder.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>

#include "haustra/embree_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/rod_curve.hpp"
#include "model/binding_arcs.hpp"
#include "sched/scheduler.hpp"

namespace haustra::detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// No ring vertex goes beyond this many template (bead) radii: a cage that would need more does not
// fit the mesh (and would bind far-away tissue).
constexpr double kMaxGrowth = 3.0;

constexpr int kMiddleRing = -1, kEndRing = -2;

struct Ring {
  std::uint32_t station = 0;
  int bead = kMiddleRing;  // local bead index, kMiddleRing or kEndRing (past an end, on the end's station)
  double template_radius = 0.0;
  double arc = 0.0;        // rest arc length of its station
  double axial = 0.0;      // its vertices' offset along the rod from the station (end rings: past the rim)
  kernels::RingPose rest;  // the station's rest pose
  [[nodiscard]] double z() const { return arc + axial; }  // its axial place in the binding pose
};

struct Shape {
  std::vector<Ring> rings;
  std::size_t m = 0;
  std::vector<double> radius;             // rings × m
  double cap_start = 0.0, cap_end = 0.0;  // axial reach of the cap vertices beyond the end rings
};

kernels::RingPose station_pose(const CageBuildInput& in, std::uint32_t station) {
  const std::uint32_t stations[1] = {station};
  kernels::RingPose pose[1];
  kernels::ring_poses(in.rest, stations, pose);
  return pose[0];
}

double station_arc(std::span<const double> arc, std::span<const double> h, std::uint32_t station) {
  return (station & 1U) != 0 ? arc[station / 2] + 0.5 * h[station / 2] : arc[station / 2];
}

std::vector<Ring> place_rings(const CageBuildInput& in, std::span<const double> arc,
                              const std::set<std::uint32_t>& dropped) {
  std::vector<Ring> rings;
  for (std::size_t b = 0; b < in.bead_node.size(); ++b) {
    Ring r;
    r.station = static_cast<std::uint32_t>(2 * in.bead_node[b]);
    r.bead = static_cast<int>(b);
    r.template_radius = in.bead_radius[b];
    rings.push_back(r);
    if (!in.desc.middle_rings || b + 1 == in.bead_node.size()) continue;
    // The station (node or section midpoint) nearest halfway in arc length, strictly between.
    const std::size_t ka = in.bead_node[b], kb = in.bead_node[b + 1];
    const double target = 0.5 * (arc[ka] + arc[kb]);
    auto best = static_cast<std::uint32_t>(2 * ka + 1);
    for (auto st = static_cast<std::uint32_t>(2 * ka + 1); st < 2 * kb; ++st)
      if (std::abs(station_arc(arc, in.section_length, st) - target) <
          std::abs(station_arc(arc, in.section_length, best) - target))
        best = st;
    Ring mid;
    mid.station = best;
    mid.bead = kMiddleRing;
    mid.template_radius = 0.5 * (in.bead_radius[b] + in.bead_radius[b + 1]);
    if (!dropped.contains(best)) rings.push_back(mid);
  }
  for (Ring& r : rings) {
    r.arc = station_arc(arc, in.section_length, r.station);
    r.rest = station_pose(in, r.station);
  }
  return rings;
}

Eigen::Vector3d ring_direction(std::size_t i, std::size_t m) {
  const double theta = 2.0 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(m);
  return {std::cos(theta), std::sin(theta), 0.0};
}

// Where a vertex's closest place jumped to another loop: its neighbours' median.
std::vector<double> neighbour_medians(const TriangleMesh& mesh, std::vector<double> s, double local) {
  const std::size_t n = mesh.vertices.size();
  std::vector<std::vector<std::uint32_t>> neighbours(n);
  for (const auto& t : mesh.triangles)
    for (int i = 0; i < 3; ++i) {
      neighbours[t[static_cast<std::size_t>(i)]].push_back(t[static_cast<std::size_t>((i + 1) % 3)]);
      neighbours[t[static_cast<std::size_t>((i + 1) % 3)]].push_back(t[static_cast<std::size_t>(i)]);
    }
  for (int sweep = 0; sweep < 4; ++sweep) {
    std::vector<double> next = s;
    for (std::size_t v = 0; v < n; ++v) {
      if (neighbours[v].empty()) continue;
      std::vector<double> around;
      for (std::uint32_t u : neighbours[v]) around.push_back(s[u]);
      std::nth_element(around.begin(), around.begin() + static_cast<std::ptrdiff_t>(around.size() / 2), around.end());
      const double median = around[around.size() / 2];
      if (std::abs(s[v] - median) > local) next[v] = median;
    }
    s.swap(next);
  }
  return s;
}

// The mesh in the binding pose: each vertex at (o_x, o_y, s + o_z) for its place s along the rod and
// its offset o in the rod's frame there. `harmonic`: s from a harmonic function on the mesh's
// surface (decision 0049), smooth and never folding. Otherwise s is the closest rod point; where
// loops of the organ touch, a vertex may lie nearer another loop's centreline: a vertex whose s
// jumps by more than `local` from the median of its neighbours takes their median instead.
std::vector<Eigen::Vector3d> binding_pose(const RodCurve& curve, const TriangleMesh& mesh, double local, bool harmonic,
                                          std::span<const double> given, CageReport& report,
                                          std::vector<double>& place) {
  const double length = curve.length();
  const std::vector<Eigen::Vector3d> point = centreline_samples(curve);
  const std::size_t n = mesh.vertices.size();
  std::vector<double> s(n, 0.0);
  report.binding = harmonic ? "harmonic" : "closest";
  if (!given.empty()) {  // the whole organ's, on this piece's stretch of it (a vertex past a cut on its end)
    if (given.size() != n)
      throw Error(ErrorCode::internal, fmt::format("{} places for {} mesh vertices", given.size(), n));
    for (std::size_t v = 0; v < n; ++v) s[v] = std::clamp(given[v], 0.0, length);
  } else if (harmonic) {
    BindingArcs arcs = harmonic_binding_arcs(mesh, point, length);
    report.binding_pieces = arcs.pieces;
    report.binding_closest_pieces = arcs.closest_pieces;
    report.binding_followed = arcs.followed;
    s = std::move(arcs.arc);
  } else {
    parallel_each(n, [&](std::size_t v) { s[v] = closest_arc(point, length, mesh.vertices[v]); });
    s = neighbour_medians(mesh, std::move(s), local);
  }
  std::vector<Eigen::Vector3d> out(n);
  parallel_each(n, [&](std::size_t v) {
    const kernels::Pose pose = curve.pose_at(s[v]);
    const Eigen::Vector3d o = pose.rotation.conjugate() * (mesh.vertices[v] - pose.position);
    out[v] = Eigen::Vector3d(o.x(), o.y(), s[v] + o.z());
  });
  place = std::move(s);
  return out;
}

// Where the mesh runs on past an end ring (an open end's rim beyond the rod's last bead, an
// oblique cut), a ring on the end's station reaches past it: the cage's end follows the rim
// instead of a long cone.
void add_end_rings(std::vector<Ring>& rings, std::span<const Eigen::Vector3d> mesh, double clearance) {
  double lo = kInf, hi = -kInf;
  for (const auto& b : mesh) {
    lo = std::min(lo, b.z());
    hi = std::max(hi, b.z());
  }
  const Ring first = rings.front(), last = rings.back();
  if (lo < first.z() - 0.5 * first.template_radius) {
    Ring r = first;
    r.bead = kEndRing;
    r.axial = lo - first.arc - clearance;
    rings.insert(rings.begin(), r);
  }
  if (hi > last.z() + 0.5 * last.template_radius) {
    Ring r = last;
    r.bead = kEndRing;
    r.axial = hi - last.arc + clearance;
    rings.push_back(r);
  }
}

// Each ring vertex's radius from the mesh around it in the binding pose: every mesh vertex between
// the ring's neighbours (beyond it, for an end ring) in the two sectors either side of the vertex's
// direction, divided by cos(π/m) so the ring's chords pass outside it too; plus the clearance. A
// sector with nothing in it takes its neighbours' larger radius (or the template).
std::vector<double> envelope_radii(const std::vector<Ring>& rings, std::size_t m, std::span<const Eigen::Vector3d> mesh,
                                   double clearance) {
  const std::size_t n = rings.size();
  std::vector<double> z(n), radius(n * m, 0.0);
  for (std::size_t g = 0; g < n; ++g) z[g] = rings[g].z();
  const double sector = 2.0 * std::numbers::pi / static_cast<double>(m);
  const double chord = 1.0 / std::cos(0.5 * sector);
  for (const auto& b : mesh) {
    const double rho = b.head<2>().norm() * chord;
    double phi = std::atan2(b.y(), b.x());
    if (phi < 0.0) phi += 2.0 * std::numbers::pi;
    const auto k = static_cast<std::size_t>(std::min(static_cast<double>(m - 1), std::floor(phi / sector)));
    // The rings whose window [z_{g−1}, z_{g+1}] holds b.z: the two either side of it.
    const auto above = static_cast<std::size_t>(std::upper_bound(z.begin(), z.end(), b.z()) - z.begin());
    for (std::size_t g : {above > 0 ? above - 1 : 0, std::min(above, n - 1)})
      for (std::size_t i : {k, (k + 1) % m}) radius[g * m + i] = std::max(radius[g * m + i], rho);
  }
  for (std::size_t g = 0; g < n; ++g) {
    std::vector<double> ring(radius.begin() + static_cast<std::ptrdiff_t>(g * m),
                             radius.begin() + static_cast<std::ptrdiff_t>((g + 1) * m));
    for (std::size_t i = 0; i < m; ++i) {
      double r = ring[i];
      if (r == 0.0) r = std::max(ring[(i + m - 1) % m], ring[(i + 1) % m]);
      if (r == 0.0) r = rings[g].template_radius;
      radius[g * m + i] = r + clearance;
    }
  }
  return radius;
}

void assemble(const Shape& shape, CageModel& cage) {
  const std::size_t m = shape.m, rings = shape.rings.size();
  cage.ring_station.clear();
  cage.ring_rest.clear();
  cage.ring_binding.clear();
  cage.ring_bead.clear();
  cage.vertex_ring.clear();
  cage.offset.clear();
  cage.binding_vertices.clear();
  cage.rest_vertices.clear();
  cage.triangles.clear();
  auto add_vertex = [&](std::size_t g, const Eigen::Vector3d& o) {
    const Ring& r = shape.rings[g];
    cage.vertex_ring.push_back(static_cast<std::uint32_t>(g));
    cage.offset.push_back(o);
    cage.binding_vertices.push_back(Eigen::Vector3d(0.0, 0.0, r.arc) + o);
    cage.rest_vertices.push_back(r.rest.centre + r.rest.rotation * o);
  };
  for (std::size_t g = 0; g < rings; ++g) {
    const Ring& r = shape.rings[g];
    cage.ring_station.push_back(r.station);
    cage.ring_rest.push_back(r.rest);
    cage.ring_binding.push_back({Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, r.arc)});
    cage.ring_bead.push_back(r.bead);
    for (std::size_t i = 0; i < m; ++i)
      add_vertex(g, shape.radius[g * m + i] * ring_direction(i, m) + Eigen::Vector3d(0.0, 0.0, r.axial));
  }
  const auto caps = static_cast<std::uint32_t>(cage.offset.size());
  add_vertex(0, Eigen::Vector3d(0.0, 0.0, shape.rings.front().axial - shape.cap_start));
  add_vertex(rings - 1, Eigen::Vector3d(0.0, 0.0, shape.rings.back().axial + shape.cap_end));
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
  std::vector<std::uint32_t> outside;                        // mesh vertices
  std::vector<std::pair<std::uint32_t, unsigned>> crossing;  // (mesh vertex of the edge, cage triangle)
  std::vector<std::pair<std::uint32_t, unsigned>> self;      // (cage vertex of the edge, cage triangle)
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

// The first triangle the open segment a→b passes through, except those `skip` rejects.
template <class Skip>
bool segment_hits(const EmbreeScene& scene, const Eigen::Vector3d& a, const Eigen::Vector3d& b, Skip skip,
                  unsigned& triangle) {
  const Eigen::Vector3d d = b - a;
  const double len = d.norm();
  if (!(len > 0.0)) return false;
  const double step = 64.0 * std::numeric_limits<float>::epsilon() * (1.0 + a.cwiseAbs().maxCoeff()) / len;
  double t = step;
  for (int guard = 0; guard < 256 && t < 1.0 - step; ++guard) {
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

// Mesh vertices outside the cage, mesh edges through it, and (check_self) cage edges through
// cage triangles they do not touch.
Problems find_problems(std::span<const Eigen::Vector3d> cage_vertices,
                       std::span<const std::array<std::uint32_t, 3>> cage_triangles,
                       std::span<const Eigen::Vector3d> mesh_vertices,
                       const std::vector<std::array<std::uint32_t, 2>>& mesh_edges, bool check_self) {
  EmbreeScene scene;
  scene.add_triangles(cage_vertices, cage_triangles);
  scene.commit();
  Problems p;
  std::vector<std::uint8_t> outside(mesh_vertices.size(), 0);
  parallel_each(mesh_vertices.size(), [&](std::size_t v) { outside[v] = scene.inside(mesh_vertices[v]) ? 0 : 1; });
  for (std::size_t v = 0; v < outside.size(); ++v)
    if (outside[v] != 0) p.outside.push_back(static_cast<std::uint32_t>(v));
  std::vector<std::int64_t> hit(mesh_edges.size(), -1);
  parallel_each(mesh_edges.size(), [&](std::size_t e) {
    unsigned tri = 0;
    if (segment_hits(
            scene, mesh_vertices[mesh_edges[e][0]], mesh_vertices[mesh_edges[e][1]], [](unsigned) { return false; },
            tri))
      hit[e] = tri;
  });
  for (std::size_t e = 0; e < hit.size(); ++e)
    if (hit[e] >= 0) p.crossing.emplace_back(mesh_edges[e][0], static_cast<unsigned>(hit[e]));
  if (check_self)
    for (const auto& e : unique_edges(cage_triangles)) {
      unsigned tri = 0;
      auto incident = [&](unsigned t) {
        const auto& c = cage_triangles[t];
        return std::find(c.begin(), c.end(), e[0]) != c.end() || std::find(c.begin(), c.end(), e[1]) != c.end();
      };
      if (segment_hits(scene, cage_vertices[e[0]], cage_vertices[e[1]], incident, tri)) p.self.emplace_back(e[0], tri);
    }
  return p;
}

std::string ring_name(const Ring& r, std::size_t g) {
  const std::size_t k = r.station / 2;
  const std::string at = (r.station & 1U) != 0 ? fmt::format("the middle of section {}", k) : fmt::format("node {}", k);
  if (r.bead >= 0) return fmt::format("ring {} (bead {} at {}, {:.3f} m along the rod)", g, r.bead, at, r.arc);
  if (r.bead == kEndRing)
    return fmt::format("ring {} (past the end at {}, {:.3f} m along the rod)", g, at, r.arc + r.axial);
  return fmt::format("ring {} (middle ring at {}, {:.3f} m along the rod)", g, at, r.arc);
}

void check_cage_input(const CageBuildInput& in) {
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
  if (in.mesh->triangles.empty()) throw FieldError(ErrorCode::invalid_geometry, in.where, "the mesh has no triangles");
}

// Every mesh vertex should lie within a few radii of the rod in the binding pose: otherwise the
// mesh is somewhere else (other units, another pose) and no cage can be grown around it.
void check_mesh_near_rod(const CageBuildInput& in, std::span<const Eigen::Vector3d> binding, double rod_length,
                         double largest_radius) {
  for (std::size_t v = 0; v < binding.size(); ++v) {
    const Eigen::Vector3d& b = binding[v];
    const double beyond = std::max({0.0, -b.z(), b.z() - rod_length});
    const double away = std::hypot(b.head<2>().norm(), beyond);
    if (away > (in.harmonic_binding ? 12.0 : 6.0) * largest_radius + 0.01)
      throw FieldError(
          ErrorCode::invalid_geometry, in.where,
          fmt::format("mesh vertex {} lies {:.4g} m from the rod, more than {} bead radii ({:.4g} m): is the "
                      "mesh around the segment's rest centreline, in metres (scale), in the same place "
                      "(translate)?",
                      v, away, in.harmonic_binding ? "twelve" : "six", largest_radius));
  }
}

// The cage's first shape, before inflation: each ring vertex at the wall plus the clearance — the
// envelope of the cross-sections around it (cross_section_rings), or the paper's template, the
// first hit of the ray from the ring's centre — and how far each may grow (`limit`); each cap just
// past the farthest mesh vertex beyond its end ring.
Shape first_shape(const CageBuildInput& in, const std::vector<double>& arc, const std::set<std::uint32_t>& dropped,
                  std::span<const Eigen::Vector3d> binding, const EmbreeScene& wall, std::vector<double>& limit) {
  Shape shape;
  const auto m = static_cast<std::size_t>(in.desc.ring_vertices);
  shape.m = m;
  shape.rings = place_rings(in, arc, dropped);
  if (in.cross_section_rings) add_end_rings(shape.rings, binding, in.clearance);
  const std::size_t rings = shape.rings.size();
  limit.assign(rings * m, 0.0);
  if (in.cross_section_rings) {
    shape.radius = envelope_radii(shape.rings, m, binding, in.clearance);
    for (std::size_t j = 0; j < rings * m; ++j)
      limit[j] = std::max(kMaxGrowth * shape.rings[j / m].template_radius, 3.0 * shape.radius[j]);
  } else {
    shape.radius.assign(rings * m, 0.0);
    for (std::size_t g = 0; g < rings; ++g) {
      const Ring& r = shape.rings[g];
      for (std::size_t i = 0; i < m; ++i) {
        const EmbreeScene::Hit h =
            wall.first_hit(Eigen::Vector3d(0.0, 0.0, r.arc), ring_direction(i, m), 0.0, kMaxGrowth * r.template_radius);
        shape.radius[g * m + i] = h.found ? h.distance + in.clearance : r.template_radius;
        limit[g * m + i] = kMaxGrowth * r.template_radius;
      }
    }
  }
  double start_reach = 0.0, end_reach = 0.0;
  for (const auto& b : binding) {
    start_reach = std::max(start_reach, shape.rings.front().z() - b.z());
    end_reach = std::max(end_reach, b.z() - shape.rings.back().z());
  }
  shape.cap_start = start_reach + in.clearance;
  shape.cap_end = end_reach + in.clearance;
  return shape;
}

// Inflation: each cage vertex moves along its own direction (radial, or axial for a cap) by what it
// takes to carry the triangle nearest a stray mesh vertex past it, in proportion to how much its
// direction points at the vertex; until nothing is outside or crossing, nothing can move, or
// max_iterations. Returns the passes made.
int inflate(const CageBuildInput& in, const std::vector<std::array<std::uint32_t, 2>>& mesh_edges,
            const std::vector<double>& limit, Shape& shape, CageModel& cage) {
  const std::size_t m = shape.m, rings = shape.rings.size();
  int pass = 0;
  for (; pass < in.desc.max_iterations; ++pass) {
    assemble(shape, cage);
    const Problems problems =
        find_problems(cage.binding_vertices, cage.triangles, cage.mesh_binding, mesh_edges, false);
    if (problems.outside.empty() && problems.crossing.empty()) break;
    EmbreeScene cage_scene;
    cage_scene.add_triangles(cage.binding_vertices, cage.triangles);
    cage_scene.commit();
    std::vector<double> need(cage.offset.size(), 0.0);
    auto push = [&](const Eigen::Vector3d& p, double extra) {
      const EmbreeScene::Hit h = cage_scene.closest(p, kInf);
      if (!h.found) return;
      const auto& tri = cage.triangles[h.triangle];
      const auto& cv = cage.binding_vertices;
      const Eigen::Vector3d q = kernels::closest_point_on_triangle(p, cv[tri[0]], cv[tri[1]], cv[tri[2]]);
      Eigen::Vector3d away = p - q;
      if (!(away.norm() > 1e-12)) away = (cv[tri[1]] - cv[tri[0]]).cross(cv[tri[2]] - cv[tri[0]]);
      away.normalize();
      for (std::uint32_t j : tri) {
        const Eigen::Vector3d dir = j < rings * m    ? ring_direction(j % m, m)
                                    : j == rings * m ? Eigen::Vector3d(-Eigen::Vector3d::UnitZ())
                                                     : Eigen::Vector3d(Eigen::Vector3d::UnitZ());
        const double c = dir.dot(away);
        const double cap = j < rings * m ? 0.5 * limit[j] : shape.rings[cage.vertex_ring[j]].template_radius;
        if (c > 0.1) need[j] = std::max(need[j], std::min((h.distance + extra) / c, cap));
      }
    };
    for (std::uint32_t v : problems.outside) push(cage.mesh_binding[v], in.clearance);
    for (const auto& [v, tri] : problems.crossing)
      for (std::uint32_t j : cage.triangles[tri]) need[j] = std::max(need[j], in.clearance);
    bool moved = false;
    for (std::size_t j = 0; j < rings * m; ++j) {
      if (need[j] <= 0.0) continue;
      const double grown = std::min(shape.radius[j] + need[j], limit[j]);
      moved = moved || grown > shape.radius[j];
      shape.radius[j] = grown;
    }
    shape.cap_start += need[rings * m];
    shape.cap_end += need[rings * m + 1];
    moved = moved || need[rings * m] > 0.0 || need[rings * m + 1] > 0.0;
    if (!moved) break;  // every push is at its limit
  }
  return pass;
}

// The ring to blame for what the final check found, and what (rings when nothing is wrong): a
// crossing of the cage itself; a mesh vertex outside; a mesh edge through it, unless the rings are
// cross-sections of a real surface, whose long edges that still cut a corner are counted, not
// refused (decision 0049).
std::size_t blame(const CageBuildInput& in, const Problems& problems, const CageModel& cage, std::size_t rings,
                  std::string& what) {
  if (!problems.self.empty()) {
    const auto& [v, tri] = problems.self.front();
    what = fmt::format("its cage crosses the cage of ring {}", cage.vertex_ring[cage.triangles[tri][0]]);
    return cage.vertex_ring[v];
  }
  if (problems.outside.empty() && (problems.crossing.empty() || in.cross_section_rings)) return rings;
  EmbreeScene cage_scene;
  cage_scene.add_triangles(cage.binding_vertices, cage.triangles);
  cage_scene.commit();
  const bool outside = !problems.outside.empty();
  const Eigen::Vector3d p =
      outside ? cage.mesh_binding[problems.outside.front()] : cage.mesh_binding[problems.crossing.front().first];
  const EmbreeScene::Hit h = cage_scene.closest(p, kInf);
  what = outside ? fmt::format("{} mesh vertices stay outside the cage (vertex {} among them)", problems.outside.size(),
                               problems.outside.front())
                 : fmt::format("{} mesh edges cross the cage", problems.crossing.size());
  return h.found ? cage.vertex_ring[cage.triangles[h.triangle][0]] : 0;
}

// The report of the cage that embeds: its rings, how far they grew, the final check, the bends.
void report_cage(const CageBuildInput& in, const CageModel& cage, const RodCurve& curve,
                 const std::vector<double>& template_radius, const Problems& final_check,
                 const std::vector<std::array<std::uint32_t, 2>>& mesh_edges, CageReport& report) {
  const std::size_t rings = cage.ring_station.size();
  const auto m = static_cast<std::size_t>(in.desc.ring_vertices);
  report.rings = rings;
  report.bead_rings = static_cast<std::size_t>(
      std::count_if(cage.ring_bead.begin(), cage.ring_bead.end(), [](int b) { return b >= 0; }));
  report.end_rings = static_cast<std::size_t>(
      std::count_if(cage.ring_bead.begin(), cage.ring_bead.end(), [](int b) { return b == kEndRing; }));
  report.middle_rings = rings - report.bead_rings - report.end_rings;
  report.ring_vertices = m;
  report.vertices = cage.offset.size();
  report.triangles = cage.triangles.size();
  report.clearance = in.clearance;
  report.inflation_min = kInf;
  report.inflation_max = -kInf;
  double sum = 0.0;
  report.tightest_bend = kInf;
  for (std::size_t g = 0; g < rings; ++g) {
    const double tmpl = template_radius[g];
    for (std::size_t i = 0; i < m; ++i) {
      const double grow = cage.offset[g * m + i].norm() - tmpl;
      report.inflation_min = std::min(report.inflation_min, grow);
      report.inflation_max = std::max(report.inflation_max, grow);
      sum += grow;
    }
    const double kappa = curve.curvature_at(cage.ring_binding[g].centre.z());
    if (kappa > 0.0) report.tightest_bend = std::min(report.tightest_bend, 1.0 / kappa);
  }
  report.inflation_mean = sum / static_cast<double>(rings * m);
  report.mesh_vertices_outside = final_check.outside.size();
  report.crossing_edges = final_check.crossing.size();
  report.self_intersections = final_check.self.size();
  // The same cage carried to the curved rest pose: where the organ bends more tightly than its
  // radius, or loops touch, it folds or overlaps there; counted for the record.
  const Problems rest = find_problems(cage.rest_vertices, cage.triangles, in.mesh->vertices, mesh_edges, false);
  report.rest_pose_outside = rest.outside.size();
}

}  // namespace

CageModel build_cage(const CageBuildInput& in, CageReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  check_cage_input(in);
  const TriangleMesh& mesh = *in.mesh;
  const auto m = static_cast<std::size_t>(in.desc.ring_vertices);
  const std::vector<std::array<std::uint32_t, 2>> mesh_edges = unique_edges(mesh.triangles);
  double largest_radius = 0.0;
  for (double r : in.bead_radius) largest_radius = std::max(largest_radius, r);
  const RodCurve curve(in.section_length, in.rest_strain,
                       kernels::Pose{in.rest.node_rotation.get(0), in.rest.node_position.get(0)});
  std::vector<double> arc(in.section_length.size() + 1, 0.0);
  for (std::size_t k = 0; k < in.section_length.size(); ++k) arc[k + 1] = arc[k] + in.section_length[k];

  CageModel cage;
  cage.mesh_binding =
      binding_pose(curve, mesh, 4.0 * largest_radius, in.harmonic_binding, in.places, report, cage.mesh_place);
  check_mesh_near_rod(in, cage.mesh_binding, curve.length(), largest_radius);
  EmbreeScene wall;
  wall.add_triangles(cage.mesh_binding, mesh.triangles);
  wall.commit();

  // Grown until it embeds the mesh; where it cannot, the middle ring nearest the trouble is taken
  // out (longer quads can span a bulge) and the cage grown afresh.
  std::set<std::uint32_t> dropped;
  for (;;) {
    std::vector<double> limit;
    Shape shape = first_shape(in, arc, dropped, cage.mesh_binding, wall, limit);
    const std::size_t rings = shape.rings.size();
    report.iterations = inflate(in, mesh_edges, limit, shape, cage) + 1;
    assemble(shape, cage);
    const Problems problems = find_problems(cage.binding_vertices, cage.triangles, cage.mesh_binding, mesh_edges, true);
    std::string what;
    const std::size_t blamed = blame(in, problems, cage, rings, what);
    if (blamed == rings) {
      std::vector<double> template_radius;
      for (const Ring& r : shape.rings) template_radius.push_back(r.template_radius);
      report.dropped_rings = dropped.size();
      report_cage(in, cage, curve, template_radius, problems, mesh_edges, report);
      report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      cage.first_station_ring = cage.ring_station.size();  // none yet: the along-rod skin adds them
      return cage;
    }
    std::size_t drop = rings;
    for (std::size_t g : {blamed, blamed + 1, blamed > 0 ? blamed - 1 : rings})
      if (g < rings && shape.rings[g].bead == kMiddleRing) {
        drop = g;
        break;
      }
    if (drop < rings) {
      dropped.insert(shape.rings[drop].station);
      continue;
    }
    double reach = 0.0;
    for (std::size_t i = 0; i < m; ++i) reach = std::max(reach, shape.radius[blamed * m + i]);
    throw FieldError(
        ErrorCode::invalid_geometry, in.where + ".cage",
        fmt::format("the cage cannot embed the mesh at {}: {}, with the cage reaching {:.1f} mm from the "
                    "rod (after {} inflation passes, {} middle rings taken out). Beads that fit the mesh "
                    "there (radius = \"mesh\"), more ring vertices or a larger cage.max_iterations may help.",
                    ring_name(shape.rings[blamed], blamed), what, 1e3 * reach, report.iterations, dropped.size()));
  }
}

}  // namespace haustra::detail
