// A mesh's vertices and edges as a graph: adjacency and Dijkstra distances.
#include "model/surface_graph.hpp"

#include <algorithm>
#include <numeric>
#include <queue>

namespace haustra::detail {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

Adjacency adjacency(const TriangleMesh& mesh) {
  std::vector<std::uint64_t> keys;
  keys.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles)
    for (int i = 0; i < 3; ++i) keys.push_back(edge_key(t[static_cast<std::size_t>(i)], t[(i + 1) % 3]));
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  const std::size_t n = mesh.vertices.size();
  Adjacency a;
  a.start.assign(n + 1, 0);
  for (std::uint64_t k : keys) {
    ++a.start[(k >> 32) + 1];
    ++a.start[(k & 0xffffffffU) + 1];
  }
  std::partial_sum(a.start.begin(), a.start.end(), a.start.begin());
  a.to.resize(a.start.back());
  a.length.resize(a.start.back());
  std::vector<std::uint32_t> fill(a.start.begin(), a.start.end() - 1);
  for (std::uint64_t k : keys) {
    const auto u = static_cast<std::uint32_t>(k >> 32), v = static_cast<std::uint32_t>(k & 0xffffffffU);
    const double len = (mesh.vertices[u] - mesh.vertices[v]).norm();
    a.to[fill[u]] = v;
    a.length[fill[u]++] = len;
    a.to[fill[v]] = u;
    a.length[fill[v]++] = len;
  }
  return a;
}

std::vector<double> dijkstra_within(const Adjacency& adj, std::size_t n, const std::vector<std::uint32_t>& from,
                                    double limit, const DistanceImproved& improved) {
  std::vector<double> dist(n, kNoPath);
  using Item = std::pair<double, std::uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> queue;
  for (std::uint32_t v : from) {
    dist[v] = 0.0;
    queue.push({0.0, v});
  }
  while (!queue.empty()) {
    const auto [d, v] = queue.top();
    queue.pop();
    if (d > dist[v]) continue;
    for (std::uint32_t e = adj.start[v]; e < adj.start[v + 1]; ++e) {
      const std::uint32_t w = adj.to[e];
      const double next = d + adj.length[e];
      if (next < dist[w] && next <= limit) {
        dist[w] = next;
        if (improved) improved(v, w, adj.length[e]);
        queue.push({next, w});
      }
    }
  }
  return dist;
}

std::vector<double> dijkstra(const Adjacency& adj, std::size_t n, const std::vector<std::uint32_t>& from) {
  return dijkstra_within(adj, n, from, kNoPath);
}

std::uint32_t farthest_vertex(const std::vector<double>& dist) {
  std::uint32_t best = 0;
  double far = -1.0;
  for (std::size_t v = 0; v < dist.size(); ++v)
    if (dist[v] < kNoPath && dist[v] > far) {
      far = dist[v];
      best = static_cast<std::uint32_t>(v);
    }
  return best;
}

}  // namespace haustra::detail
