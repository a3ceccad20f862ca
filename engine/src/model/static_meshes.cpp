// Static meshes of the environment, obstacles and containers: loaded, checked and put in Embree scenes.
#include "model/static_meshes.hpp"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "haustra/error.hpp"
#include "haustra/kernels/contact_geometry.hpp"
#include "haustra/mesh_io.hpp"
#include "model/surface_graph.hpp"

namespace haustra::detail {

StaticMeshes::StaticMeshes(const std::vector<MeshObstacleDesc>& descs) {
  if (descs.empty()) return;
  for (std::size_t m = 0; m < descs.size(); ++m) {
    const MeshObstacleDesc& d = descs[m];
    Mesh mesh;
    mesh.vertices = d.vertices;
    mesh.triangles = d.triangles;
    mesh.closed = is_closed(TriangleMesh{d.vertices, d.triangles});
    // A container's inside is where its volume is: wound inward, it is turned (the pseudo-normals
    // and the inside test both read the winding as outward).
    if (d.container && mesh_volume(mesh.vertices, mesh.triangles) < 0.0)
      for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
    mesh.vertex_normal.assign(mesh.vertices.size(), Eigen::Vector3d::Zero());
    for (const auto& t : mesh.triangles) {
      const Eigen::Vector3d& a = mesh.vertices[t[0]];
      const Eigen::Vector3d& b = mesh.vertices[t[1]];
      const Eigen::Vector3d& c = mesh.vertices[t[2]];
      const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
      mesh.face_normal.push_back(n.allFinite() ? n : Eigen::Vector3d::UnitZ());
      const Eigen::Vector3d corners[3] = {a, b, c};
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d e1 = (corners[(i + 1) % 3] - corners[i]).normalized();
        const Eigen::Vector3d e2 = (corners[(i + 2) % 3] - corners[i]).normalized();
        const double angle = std::acos(std::clamp(e1.dot(e2), -1.0, 1.0));
        if (std::isfinite(angle)) mesh.vertex_normal[t[static_cast<std::size_t>(i)]] += angle * mesh.face_normal.back();
        // try_emplace with zero: a default Eigen vector is uninitialized (this once made the edge
        // pseudo-normals, and so which side of the bolster a bead was on, vary from run to run).
        mesh.edge_normal
            .try_emplace(edge_key(t[static_cast<std::size_t>(i)], t[static_cast<std::size_t>((i + 1) % 3)]),
                         Eigen::Vector3d::Zero())
            .first->second += mesh.face_normal.back();
      }
    }
    if (d.container) {
      auto scene = std::make_unique<EmbreeScene>();
      scene->add_triangles(mesh.vertices, mesh.triangles);
      scene->commit();
      containers_.push_back(std::move(scene));
      container_mesh_.push_back(static_cast<std::uint32_t>(m));
      meshes_.push_back(std::move(mesh));
      container_grid_.push_back(depth_grid(containers_.size() - 1));
      continue;
    } else {
      if (!obstacles_) obstacles_ = std::make_unique<EmbreeScene>();
      obstacles_->add_triangles(mesh.vertices, mesh.triangles);
      obstacle_mesh_.push_back(static_cast<std::uint32_t>(m));
    }
    meshes_.push_back(std::move(mesh));
  }
  if (obstacles_) obstacles_->commit();
}

StaticMeshes::~StaticMeshes() = default;

std::pair<Eigen::Vector3d, Eigen::Vector3d> StaticMeshes::closest_feature(const Mesh& mesh, std::uint32_t triangle,
                                                                          const Eigen::Vector3d& p) {
  const auto& t = mesh.triangles[triangle];
  const Eigen::Vector3d& a = mesh.vertices[t[0]];
  const Eigen::Vector3d& b = mesh.vertices[t[1]];
  const Eigen::Vector3d& c = mesh.vertices[t[2]];
  const Eigen::Vector3d point = kernels::closest_point_on_triangle(p, a, b, c);
  // Which feature holds the closest point: the pseudo-normal of that feature tells the side.
  const double scale = std::max({(b - a).norm(), (c - a).norm(), 1e-300});
  const double tol = 1e-9 * scale;
  Eigen::Vector3d normal = mesh.face_normal[triangle];
  const Eigen::Vector3d corners[3] = {a, b, c};
  bool on_vertex = false;
  for (int i = 0; i < 3; ++i)
    if ((point - corners[i]).norm() <= tol) {
      normal = mesh.vertex_normal[t[static_cast<std::size_t>(i)]];
      on_vertex = true;
    }
  if (!on_vertex)
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d& e0 = corners[i];
      const Eigen::Vector3d& e1 = corners[(i + 1) % 3];
      if ((kernels::closest_point_on_segment(point, e0, e1) - point).norm() <= tol) {
        const auto it =
            mesh.edge_normal.find(edge_key(t[static_cast<std::size_t>(i)], t[static_cast<std::size_t>((i + 1) % 3)]));
        if (it != mesh.edge_normal.end()) normal = it->second;
      }
    }
  return {point, normal.normalized()};
}

StaticMeshes::Hit StaticMeshes::closest(const Eigen::Vector3d& p, double radius) const {
  Hit hit;
  if (!obstacles_) return hit;
  const EmbreeScene::Hit found = obstacles_->closest(p, radius);
  if (!found.found) return hit;
  const std::uint32_t index = obstacle_mesh_[found.geometry];
  const Mesh& mesh = meshes_[index];
  const auto [point, normal] = closest_feature(mesh, found.triangle, p);
  const auto& t = mesh.triangles[found.triangle];
  const double tol = 1e-9 * std::max({(mesh.vertices[t[1]] - mesh.vertices[t[0]]).norm(),
                                      (mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm(), 1e-300});
  const double distance = found.distance;
  const Eigen::Vector3d away = p - point;
  hit.found = true;
  hit.mesh = index;
  hit.point = point;
  if (mesh.closed) {
    const bool inside = away.dot(normal) < 0.0;
    hit.push = distance > tol ? Eigen::Vector3d((inside ? -away : away) / distance) : normal;
    hit.signed_distance = inside ? -distance : distance;
  } else {
    hit.push = distance > tol ? Eigen::Vector3d(away / distance) : normal;
    hit.signed_distance = distance;
  }
  return hit;
}

// p's depth inside container c (< 0 outside), its distance to the surface known to be below `bound`.
double StaticMeshes::signed_depth(std::size_t c, const Eigen::Vector3d& p, double bound) const {
  const EmbreeScene::Hit found = containers_[c]->closest(p, bound);
  if (!found.found) return 0.0;  // (bound is an upper bound: never here)
  const auto [point, normal] = closest_feature(meshes_[container_mesh_[c]], found.triangle, p);
  return (p - point).dot(normal) < 0.0 ? found.distance : -found.distance;
}

// Cells a 32nd of the box's longest side; each centre's depth found within its neighbour's
// distance plus their spacing (a distance is 1-Lipschitz), so each query is short.
StaticMeshes::DepthGrid StaticMeshes::depth_grid(std::size_t c) const {
  const Mesh& mesh = meshes_[container_mesh_[c]];
  Eigen::Vector3d lo = mesh.vertices.front(), hi = lo;
  for (const auto& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  DepthGrid g;
  g.cell = std::max((hi - lo).maxCoeff(), 1e-9) / 32.0;
  g.lo = lo;
  for (int i = 0; i < 3; ++i)
    g.n[static_cast<std::size_t>(i)] = std::max(1, static_cast<int>(std::ceil((hi[i] - lo[i]) / g.cell)));
  g.depth.reserve(static_cast<std::size_t>(g.n[0]) * static_cast<std::size_t>(g.n[1]) *
                  static_cast<std::size_t>(g.n[2]));
  double last = std::numeric_limits<double>::infinity();
  for (int k = 0; k < g.n[2]; ++k)
    for (int j = 0; j < g.n[1]; ++j)
      for (int i = 0; i < g.n[0]; ++i) {
        const Eigen::Vector3d centre = lo + g.cell * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        // The previous centre is at most a row's or a layer's length away: its distance plus that bounds this one's.
        const double reach = std::abs(last) + g.cell * (2.0 + g.n[0] + g.n[1]);
        last = signed_depth(c, centre, std::isfinite(reach) ? reach : std::numeric_limits<double>::infinity());
        g.depth.push_back(last);
      }
  return g;
}

double StaticMeshes::DepthGrid::deeper_than(const Eigen::Vector3d& p) const {
  std::array<int, 3> at{};
  for (std::size_t i = 0; i < 3; ++i) {
    const double x = std::floor((p[static_cast<int>(i)] - lo[static_cast<int>(i)]) / cell);
    if (!(x >= 0.0 && x < n[i])) return -std::numeric_limits<double>::infinity();  // off the grid
    at[i] = static_cast<int>(x);
  }
  const Eigen::Vector3d centre = lo + cell * Eigen::Vector3d(at[0] + 0.5, at[1] + 0.5, at[2] + 0.5);
  const std::size_t index =
      (static_cast<std::size_t>(at[2]) * static_cast<std::size_t>(n[1]) + static_cast<std::size_t>(at[1])) *
          static_cast<std::size_t>(n[0]) +
      static_cast<std::size_t>(at[0]);
  return depth[index] - (p - centre).norm();
}

StaticMeshes::Hit StaticMeshes::container_contact(std::size_t c, const Eigen::Vector3d& p, double reach) const {
  Hit hit;
  // Deeper than the reach everywhere around p's cell: free, as the queries below would say.
  const double deeper_than = container_grid_[c].deeper_than(p);
  if (deeper_than > reach) return hit;
  const EmbreeScene& scene = *containers_[c];
  EmbreeScene::Hit found = scene.closest(p, reach);
  if (!found.found) {
    // Farther than `reach` from the wall: deep inside (free: the grid or the rays say inside), or
    // out, however far (held back).
    if (deeper_than > 0.0 || scene.inside(p)) return hit;
    found = scene.closest(p, std::numeric_limits<double>::infinity());
    if (!found.found) return hit;
  }
  const std::uint32_t index = container_mesh_[c];
  const Mesh& mesh = meshes_[index];
  const auto [point, normal] = closest_feature(mesh, found.triangle, p);
  const auto& t = mesh.triangles[found.triangle];
  const double tol = 1e-9 * std::max({(mesh.vertices[t[1]] - mesh.vertices[t[0]]).norm(),
                                      (mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm(), 1e-300});
  const double distance = found.distance;
  const Eigen::Vector3d away = p - point;
  const bool inside = away.dot(normal) < 0.0;
  hit.found = true;
  hit.mesh = index;
  hit.point = point;
  // Inward: from the wall towards p inside, from p towards the wall outside.
  hit.push = distance > tol ? Eigen::Vector3d((inside ? away : -away) / distance) : Eigen::Vector3d(-normal);
  hit.signed_distance = inside ? distance : -distance;
  return hit;
}

}  // namespace haustra::detail
