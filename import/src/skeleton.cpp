// CGAL: polygon soup → oriented Surface_mesh → holes filled → mean curvature flow skeleton →
// the longest path through it (two Dijkstra sweeps over the skeleton graph).
#include "skeleton.hpp"

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/extract_mean_curvature_flow_skeleton.h>
#include <fmt/format.h>

#include <chrono>
#include <queue>

#include "haustra/error.hpp"

namespace haustra::import {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Skeletonization = CGAL::Mean_curvature_flow_skeletonization<Mesh>;
using Skeleton = Skeletonization::Skeleton;
namespace PMP = CGAL::Polygon_mesh_processing;

Mesh closed_mesh(const TriangleMesh& in, const std::string& where, int& holes) {
  std::vector<Point> points;
  points.reserve(in.vertices.size());
  for (const auto& v : in.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> faces;
  faces.reserve(in.triangles.size());
  for (const auto& t : in.triangles) faces.push_back({t[0], t[1], t[2]});
  PMP::repair_polygon_soup(points, faces);
  PMP::orient_polygon_soup(points, faces);
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(points, faces, mesh);
  std::vector<Mesh::Halfedge_index> borders;
  for (Mesh::Halfedge_index h : mesh.halfedges())
    if (mesh.is_border(h)) borders.push_back(h);
  std::vector<bool> done(mesh.number_of_halfedges(), false);
  for (Mesh::Halfedge_index h : borders) {
    if (done[h.idx()] || !mesh.is_border(h)) continue;
    for (Mesh::Halfedge_index g : CGAL::halfedges_around_face(h, mesh)) done[g.idx()] = true;
    std::vector<Mesh::Face_index> patch;
    PMP::triangulate_and_refine_hole(mesh, h, std::back_inserter(patch), CGAL::Emptyset_iterator());
    ++holes;
  }
  if (!CGAL::is_closed(mesh))
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: the surface cannot be closed for skeletonization (after filling {} holes it still has "
                            "open edges): give its midline with --centreline",
                            where, holes));
  return mesh;
}

// Farthest skeleton vertex from `from` along skeleton edges, and each vertex's predecessor.
std::pair<std::size_t, std::vector<std::size_t>> farthest(const Skeleton& s, std::size_t from) {
  const std::size_t n = boost::num_vertices(s);
  std::vector<double> dist(n, 1e300);
  std::vector<std::size_t> prev(n, n);
  using Item = std::pair<double, std::size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  dist[from] = 0.0;
  queue.push({0.0, from});
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    for (auto [e, end] = boost::out_edges(v, s); e != end; ++e) {
      const std::size_t w = boost::target(*e, s);
      const double len = std::sqrt(CGAL::squared_distance(s[v].point, s[w].point));
      if (d + len < dist[w]) {
        dist[w] = d + len;
        prev[w] = v;
        queue.push({dist[w], w});
      }
    }
  }
  std::size_t best = from;
  for (std::size_t v = 0; v < n; ++v)
    if (dist[v] < 1e300 && dist[v] > dist[best]) best = v;
  return {best, prev};
}

}  // namespace

SkeletonResult skeleton_path(const TriangleMesh& in, const std::string& where) {
  const auto t0 = std::chrono::steady_clock::now();
  SkeletonResult r;
  Mesh mesh = closed_mesh(in, where, r.holes_filled);
  Skeleton skeleton;
  CGAL::extract_mean_curvature_flow_skeleton(mesh, skeleton);
  r.skeleton_vertices = boost::num_vertices(skeleton);
  if (r.skeleton_vertices < 2)
    throw Error(
        ErrorCode::invalid_geometry,
        fmt::format("{}: the surface's skeleton has {} vertices: no tube to follow", where, r.skeleton_vertices));
  for (std::size_t v = 0; v < r.skeleton_vertices; ++v) r.branches += boost::out_degree(v, skeleton) >= 3 ? 1 : 0;
  const std::size_t a = farthest(skeleton, 0).first;
  const auto [b, prev] = farthest(skeleton, a);
  for (std::size_t v = b; v != a; v = prev[v]) {
    const Point& p = skeleton[v].point;
    r.path.emplace_back(p.x(), p.y(), p.z());
  }
  const Point& p = skeleton[a].point;
  r.path.emplace_back(p.x(), p.y(), p.z());
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace haustra::import
