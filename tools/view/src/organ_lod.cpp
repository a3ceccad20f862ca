// Vertex clustering per chunk (Rossignac and Borrel's, with a mesh vertex as each cell's
// representative) and the per-frame choice of levels under a triangle budget.
#include "organ_lod.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <queue>
#include <tuple>
#include <unordered_map>

namespace haustra::view {
namespace {

using Triangle = std::array<std::uint32_t, 3>;

struct CellKey {
  std::int64_t x, y, z;
  int facing;  // the normal's dominant axis and sign: a cell never joins a cap to its tube's side
  bool operator==(const CellKey&) const = default;
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    return static_cast<std::size_t>(k.x * 73856093) ^ static_cast<std::size_t>(k.y * 19349663) ^
           static_cast<std::size_t>(k.z * 83492791) ^ static_cast<std::size_t>(k.facing * 2654435761u);
  }
};

double mean_edge_length(std::span<const Eigen::Vector3d> p, std::span<const Triangle> triangles) {
  double sum = 0.0;
  for (const Triangle& t : triangles)
    sum += (p[t[0]] - p[t[1]]).norm() + (p[t[1]] - p[t[2]]).norm() + (p[t[2]] - p[t[0]]).norm();
  return triangles.empty() ? 0.0 : sum / (3.0 * static_cast<double>(triangles.size()));
}

int facing(const Eigen::Vector3d& n) {
  int axis = 0;
  n.cwiseAbs().maxCoeff(&axis);
  return 2 * axis + (n[axis] < 0.0 ? 1 : 0);
}

// Each vertex's representative at cell size `cell`: itself when locked (shared with another chunk),
// else the vertex of its cell (and facing) nearest the cell's mean (the lowest index on a tie).
std::unordered_map<std::uint32_t, std::uint32_t> cluster(std::span<const Eigen::Vector3d> p,
                                                         std::span<const Eigen::Vector3d> normals,
                                                         const std::vector<std::uint32_t>& vertices,
                                                         const std::vector<bool>& locked, double cell) {
  std::unordered_map<CellKey, std::vector<std::uint32_t>, CellHash> cells;
  std::unordered_map<std::uint32_t, std::uint32_t> rep;
  for (std::uint32_t v : vertices) {
    if (locked[v]) {
      rep[v] = v;
      continue;
    }
    const Eigen::Vector3d q = p[v] / cell;
    cells[{static_cast<std::int64_t>(std::floor(q.x())), static_cast<std::int64_t>(std::floor(q.y())),
           static_cast<std::int64_t>(std::floor(q.z())), v < normals.size() ? facing(normals[v]) : 0}]
        .push_back(v);
  }
  for (auto& [key, members] : cells) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (std::uint32_t v : members) mean += p[v];
    mean /= static_cast<double>(members.size());
    std::uint32_t best = members.front();
    for (std::uint32_t v : members)
      if (const double d = (p[v] - mean).squaredNorm(), e = (p[best] - mean).squaredNorm();
          d < e || (d == e && v < best))
        best = v;
    for (std::uint32_t v : members) rep[v] = best;
  }
  return rep;
}

// The chunk's triangles through the representatives: collapsed ones dropped, and a triangle that
// comes out an even number of times (a fold flattened onto itself) dropped too, so a closed
// surface stays closed (every edge used an even number of times).
std::vector<Triangle> simplify(std::span<const Triangle> triangles,
                               const std::unordered_map<std::uint32_t, std::uint32_t>& rep) {
  std::map<Triangle, std::pair<int, Triangle>> seen;  // sorted vertices -> (count, first as wound)
  std::vector<Triangle> order;
  for (const Triangle& t : triangles) {
    const Triangle r{rep.at(t[0]), rep.at(t[1]), rep.at(t[2])};
    if (r[0] == r[1] || r[1] == r[2] || r[2] == r[0]) continue;
    Triangle key = r;
    std::sort(key.begin(), key.end());
    auto [it, fresh] = seen.try_emplace(key, 0, r);
    if (fresh) order.push_back(key);
    ++it->second.first;
  }
  std::vector<Triangle> out;
  for (const Triangle& key : order)
    if (const auto& [count, wound] = seen.at(key); count % 2 == 1) out.push_back(wound);
  return out;
}

// Appends a block: the triangles' vertices (in first use order) and their local indices.
LodBlock append_block(OrganLod& lod, const std::vector<Triangle>& triangles) {
  LodBlock b;
  b.first_vertex = static_cast<std::uint32_t>(lod.source.size());
  b.first_index = static_cast<std::uint32_t>(lod.indices.size());
  std::unordered_map<std::uint32_t, std::uint32_t> local;
  for (const Triangle& t : triangles)
    for (std::uint32_t v : t) {
      auto [it, fresh] = local.try_emplace(v, static_cast<std::uint32_t>(local.size()));
      if (fresh) lod.source.push_back(v);
      lod.indices.push_back(it->second);
    }
  b.vertex_count = static_cast<std::uint32_t>(local.size());
  b.index_count = static_cast<std::uint32_t>(lod.indices.size()) - b.first_index;
  return b;
}

}  // namespace

OrganLod build_organ_lod(std::span<const Eigen::Vector3d> positions, std::span<const Eigen::Vector3d> normals,
                         std::span<const Triangle> triangles, std::span<const std::uint32_t> vertex_node,
                         std::span<const Eigen::Vector3d> nodes, std::size_t triangles_per_chunk) {
  OrganLod lod;
  lod.mean_edge = mean_edge_length(positions, triangles);
  if (triangles.empty()) return lod;
  // Chunks: runs of nodes holding about triangles_per_chunk triangles (a triangle goes with its
  // first vertex's node); nodes are numbered along each segment's centreline.
  std::uint32_t node_count = 0;
  for (const Triangle& t : triangles) node_count = std::max(node_count, vertex_node[t[0]] + 1);
  std::vector<std::size_t> per_node(node_count, 0);
  for (const Triangle& t : triangles) ++per_node[vertex_node[t[0]]];
  std::vector<std::uint32_t> chunk_of_node(node_count, 0);
  std::vector<std::uint32_t> first_node{0};
  for (std::uint32_t k = 0, in_chunk = 0; k < node_count; ++k) {
    if (in_chunk >= triangles_per_chunk) {
      first_node.push_back(k);
      in_chunk = 0;
    }
    chunk_of_node[k] = static_cast<std::uint32_t>(first_node.size() - 1);
    in_chunk += static_cast<std::uint32_t>(per_node[k]);
  }
  const std::size_t chunk_count = first_node.size();
  std::vector<std::vector<Triangle>> chunk_triangles(chunk_count);
  for (const Triangle& t : triangles) chunk_triangles[chunk_of_node[vertex_node[t[0]]]].push_back(t);
  // A vertex used by two chunks is locked: kept at every level of both.
  std::vector<std::int64_t> owner(positions.size(), -1);
  std::vector<bool> locked(positions.size(), false);
  for (std::size_t c = 0; c < chunk_count; ++c)
    for (const Triangle& t : chunk_triangles[c])
      for (std::uint32_t v : t) {
        if (owner[v] >= 0 && owner[v] != static_cast<std::int64_t>(c)) locked[v] = true;
        owner[v] = static_cast<std::int64_t>(c);
      }
  for (std::size_t c = 0; c < chunk_count; ++c) {
    const std::vector<Triangle>& own = chunk_triangles[c];
    LodChunk chunk;
    chunk.first_node = first_node[c];
    chunk.node_count = (c + 1 < chunk_count ? first_node[c + 1] : node_count) - first_node[c];
    std::vector<std::uint32_t> vertices;
    for (const Triangle& t : own) vertices.insert(vertices.end(), t.begin(), t.end());
    std::sort(vertices.begin(), vertices.end());
    vertices.erase(std::unique(vertices.begin(), vertices.end()), vertices.end());
    // Its reach: how far its vertices lie from the nearest of its nodes (the sphere that culls it).
    for (std::uint32_t v : vertices) {
      double nearest = 1e300;
      for (std::uint32_t k = chunk.first_node; k < chunk.first_node + chunk.node_count && k < nodes.size(); ++k)
        nearest = std::min(nearest, (positions[v] - nodes[k]).norm());
      chunk.reach = std::max(chunk.reach, nearest);
    }
    chunk.levels[0] = append_block(lod, own);
    for (int level = 1; level < kLodLevels; ++level)
      chunk.levels[static_cast<std::size_t>(level)] =
          append_block(lod, simplify(own, cluster(positions, normals, vertices, locked, lod.cell(level))));
    lod.chunks.push_back(chunk);
  }
  return lod;
}

void choose_lod_levels(const OrganLod& lod, std::span<const Eigen::Vector3d> nodes, const LodView& view,
                       std::size_t triangle_budget, std::span<int> level_out) {
  // The view's six planes (Gribb and Hartmann), each as n.x + d >= 0 inside.
  std::array<Eigen::Vector4d, 6> planes;
  const Eigen::Matrix4d& m = view.view_projection;
  for (int i = 0; i < 3; ++i) {
    planes[static_cast<std::size_t>(2 * i)] = m.row(3) + m.row(i);
    planes[static_cast<std::size_t>(2 * i + 1)] = m.row(3) - m.row(i);
  }
  for (Eigen::Vector4d& p : planes) p /= p.head<3>().norm();
  constexpr int kCoarsest = kLodLevels - 1;
  std::size_t drawn = 0;
  using Candidate = std::tuple<double, std::size_t>;  // pixels a cell spans now, chunk (larger first)
  std::vector<double> pixels_per_metre(lod.chunks.size(), 0.0);
  std::priority_queue<Candidate> queue;
  for (std::size_t c = 0; c < lod.chunks.size() && c < level_out.size(); ++c) {
    const LodChunk& chunk = lod.chunks[c];
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
    for (std::uint32_t k = chunk.first_node; k < chunk.first_node + chunk.node_count && k < nodes.size(); ++k) {
      lo = lo.cwiseMin(nodes[k]);
      hi = hi.cwiseMax(nodes[k]);
    }
    level_out[c] = -1;
    if (chunk.node_count == 0 || lo.x() > hi.x()) continue;
    const Eigen::Vector3d centre = 0.5 * (lo + hi);
    const double radius = 0.5 * (hi - lo).norm() + 1.5 * chunk.reach;  // stretched since build: some room
    bool inside = true;
    for (const Eigen::Vector4d& p : planes) inside = inside && p.head<3>().dot(centre) + p.w() >= -radius;
    if (!inside) continue;
    const double distance = std::max((centre - view.eye).norm() - radius, 1e-3);
    pixels_per_metre[c] = view.pixels_per_radian / distance;
    level_out[c] = kCoarsest;
    drawn += chunk.levels[kCoarsest].index_count / 3;
    queue.emplace(lod.cell(kCoarsest) * pixels_per_metre[c], c);
  }
  // Finest first where it shows most; a chunk whose next level does not fit leaves the queue.
  while (!queue.empty()) {
    const auto [pixels, c] = queue.top();
    queue.pop();
    if (pixels <= 1.0) break;
    const LodChunk& chunk = lod.chunks[c];
    const int level = level_out[c];
    const std::size_t now = chunk.levels[static_cast<std::size_t>(level)].index_count / 3,
                      next = chunk.levels[static_cast<std::size_t>(level - 1)].index_count / 3;
    if (drawn - now + next > triangle_budget) continue;
    drawn = drawn - now + next;
    level_out[c] = level - 1;
    if (level - 1 > 0) queue.emplace(lod.cell(level - 1) * pixels_per_metre[c], c);
  }
}

}  // namespace haustra::view
