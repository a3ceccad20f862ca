// Where a segmentation fused two loops of an organ into one wall, the surface cut back into two walls.
#include "model/fused_contacts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <numeric>

#include "haustra/error.hpp"
#include "model/binding_arcs.hpp"

namespace haustra::detail {
namespace {

// A jump in place is a cut only when it is this many times the longest edge round the vertex (the
// HuBMAP ileum's necks: over 10×, and no edge between 5× and 10×; decision 0118).
constexpr double kJumpEdges = 10.0;

// The triangles round each vertex (CSR), each list in the triangles' order.
void triangles_round(const TriangleMesh& mesh, std::vector<std::uint32_t>& start, std::vector<std::uint32_t>& list) {
  start.assign(mesh.vertices.size() + 1, 0);
  for (const auto& t : mesh.triangles)
    for (std::uint32_t v : t) ++start[v + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  list.resize(start.back());
  std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
  for (std::uint32_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t v : mesh.triangles[t]) list[next[v]++] = t;
}

}  // namespace

FusedCut cut_fused_contacts(TriangleMesh& mesh, std::vector<double>& place, double jump,
                            std::span<const Eigen::Vector3d> samples, double length) {
  const std::size_t n = mesh.vertices.size();
  // A triangle's place: its corners' median (one corner across a cut does not move it).
  std::vector<double> at(mesh.triangles.size());
  for (std::size_t t = 0; t < at.size(); ++t) {
    std::array<double, 3> s = {place[mesh.triangles[t][0]], place[mesh.triangles[t][1]], place[mesh.triangles[t][2]]};
    std::sort(s.begin(), s.end());
    at[t] = s[1];
  }
  std::vector<std::uint32_t> start, round;
  triangles_round(mesh, start, round);
  FusedCut out;
  std::vector<std::uint32_t> here;
  for (std::uint32_t v = 0; v < n; ++v) {
    here.assign(round.begin() + start[v], round.begin() + start[v + 1]);
    std::stable_sort(here.begin(), here.end(), [&](std::uint32_t a, std::uint32_t b) { return at[a] < at[b]; });
    // Groups of triangles whose places run on without a jump; the vertex stays with the group
    // nearest its own place, each other group takes a copy. A jump is also far longer than the
    // triangles round the vertex (a neck's places jump by hundreds of edge lengths across one edge):
    // a coarse tube whose triangles span more than `jump` along it is one wall, not two.
    double longest = 0.0;
    for (const std::uint32_t t : here)
      for (std::size_t c = 0; c < 3; ++c)
        longest = std::max(
            longest, (mesh.vertices[mesh.triangles[t][c]] - mesh.vertices[mesh.triangles[t][(c + 1) % 3]]).norm());
    const double apart = std::max(jump, kJumpEdges * longest);
    std::vector<std::size_t> group_start = {0};
    for (std::size_t i = 1; i < here.size(); ++i)
      if (at[here[i]] - at[here[i - 1]] > apart) group_start.push_back(i);
    if (group_start.size() < 2) continue;
    group_start.push_back(here.size());
    std::size_t own = 0;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t g = 0; g + 1 < group_start.size(); ++g)
      for (std::size_t i = group_start[g]; i < group_start[g + 1]; ++i)
        if (const double d = std::abs(at[here[i]] - place[v]); d < nearest) nearest = d, own = g;
    for (std::size_t g = 0; g + 1 < group_start.size(); ++g) {
      if (g == own) continue;
      const auto copy = static_cast<std::uint32_t>(mesh.vertices.size());
      if (mesh.vertices.size() >= kMaxMeshVertices)
        throw Error(ErrorCode::invalid_geometry,
                    fmt::format("cutting the surface where loops are fused would pass the largest mesh the engine "
                                "takes ({} vertices)",
                                kMaxMeshVertices));
      const double middle = at[here[(group_start[g] + group_start[g + 1]) / 2]];
      mesh.vertices.push_back(mesh.vertices[v]);
      place.push_back(closest_arc_within(samples, length, mesh.vertices[v], middle - jump, middle + jump));
      for (std::size_t i = group_start[g]; i < group_start[g + 1]; ++i)
        for (std::uint32_t& corner : mesh.triangles[here[i]])
          if (corner == v) corner = copy;
      ++out.copies;
    }
    ++out.vertices_cut;
  }
  return out;
}

}  // namespace haustra::detail
