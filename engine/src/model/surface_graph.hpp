#pragma once
// A triangle mesh as a graph of its vertices and edges: neighbours with edge lengths, and distances
// along the edges (Dijkstra, ties broken by vertex index, so the same mesh gives the same answer).
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra::detail {

inline constexpr double kNoPath = std::numeric_limits<double>::infinity();

// An undirected edge as one number, the lower vertex first.
std::uint64_t edge_key(std::uint32_t a, std::uint32_t b);

// Vertex neighbours with edge lengths (CSR), each list ascending.
struct Adjacency {
  std::vector<std::uint32_t> start, to;
  std::vector<double> length;
};
Adjacency adjacency(const TriangleMesh& mesh);

// Distances along the edges from a set of vertices, stopping at `limit` (beyond it: kNoPath).
// `improved(v, w, edge)`, if given, is told each time w's distance improves by way of v.
using DistanceImproved = std::function<void(std::uint32_t, std::uint32_t, double)>;
std::vector<double> dijkstra_within(const Adjacency& adj, std::size_t n, const std::vector<std::uint32_t>& from,
                                    double limit, const DistanceImproved& improved = {});
std::vector<double> dijkstra(const Adjacency& adj, std::size_t n, const std::vector<std::uint32_t>& from);

// The vertex of largest finite distance (the lowest index among equals).
std::uint32_t farthest_vertex(const std::vector<double>& dist);

}  // namespace haustra::detail
