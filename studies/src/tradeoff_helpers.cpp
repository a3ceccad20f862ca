// What the speed/accuracy study's knobs share: positions, distances, a frame's cost, a converged
// reference, the paper's cantilever.
#include <algorithm>

#include "tradeoff_knobs.hpp"

namespace haustra::validation::tradeoff {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Eigen::Vector3d node(const World& w, std::size_t k) {
  const auto p = w.node_positions();
  return {p.x[k], p.y[k], p.z[k]};
}

std::vector<Eigen::Vector3d> nodes(const World& w) {
  std::vector<Eigen::Vector3d> out(w.node_count());
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = node(w, k);
  return out;
}

double max_distance(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double worst = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) worst = std::max(worst, (a[k] - b[k]).norm());
  return worst;
}

// Median engine-measured frame time over `frames` further frames, µs.
double frame_cost(World& w, int frames) {
  std::vector<double> t;
  for (int f = 0; f < frames; ++f) {
    w.step();
    t.push_back(w.last_profile().frame_seconds * 1e6);
  }
  return median(t);
}

// Solve each frame to convergence and let the guard allow any jump: a static reference.
void converge_each_frame(WorldDesc& d) {
  d.solver.iterations = 60;
  d.solver.max_iterations = 60;
  d.solver.tolerance = 1e-13;
  d.solver.max_displacement = 1e6;
}

// The paper's tube (R = 2 cm, 3 mm wall, E = 33.2 kPa), all strains elastic, clamped level.
WorldDesc cantilever(int nodes) {
  WorldDesc d;
  d.threads = 1;
  SegmentDesc s;
  s.nodes = nodes;
  s.rest.length = kRodLength;
  s.law = {StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic, StrainLaw::elastic};
  s.base_position = {0.0, 0.0, 0.5};
  d.segments.push_back(s);
  return d;
}

std::filesystem::path scene_file(const std::string& name) {
  return std::filesystem::path(HAUSTRA_DEFAULT_ASSETS).parent_path() / (name + ".toml");
}

}  // namespace haustra::validation::tradeoff
