// The run-time parameters a checkpoint carries (decision 0099): read from a world's description,
// put back into a description and its model.
#include <cstring>

#include "io/checkpoint.hpp"

namespace haustra::detail {

RunTimeParameters parameters_of(const WorldDesc& desc) {
  RunTimeParameters p;
  p.gravity = desc.gravity;
  p.dt = desc.dt;
  p.frame_budget = desc.frame_budget;
  p.max_substeps = desc.solver.max_substeps;
  p.max_retries = desc.solver.max_retries;
  p.calm_frames = desc.solver.calm_frames;
  for (const InstrumentDesc& in : desc.instruments)
    p.couplings.push_back({in.coupling_stiffness, in.coupling_damping, in.force_limit});
  for (const SegmentDesc& s : desc.segments) p.materials.push_back({s.material, s.relaxation_time});
  return p;
}

void apply_parameters(const RunTimeParameters& p, WorldDesc& desc) {
  desc.gravity = p.gravity;
  desc.dt = p.dt;
  desc.frame_budget = p.frame_budget;
  desc.solver.max_substeps = p.max_substeps;
  desc.solver.max_retries = p.max_retries;
  desc.solver.calm_frames = p.calm_frames;
  for (std::size_t i = 0; i < desc.instruments.size() && i < p.couplings.size(); ++i) {
    desc.instruments[i].coupling_stiffness = p.couplings[i].stiffness;
    desc.instruments[i].coupling_damping = p.couplings[i].damping;
    desc.instruments[i].force_limit = p.couplings[i].force_limit;
  }
  for (std::size_t s = 0; s < desc.segments.size() && s < p.materials.size(); ++s) {
    desc.segments[s].material = p.materials[s].material;
    desc.segments[s].relaxation_time = p.materials[s].relaxation_time;
  }
}

void apply_parameters(const RunTimeParameters& p, WorldModel& model) {
  model.gravity = p.gravity;
  model.dt = p.dt;
  model.frame_budget = p.frame_budget;
  model.solver.max_substeps = p.max_substeps;
  model.solver.max_retries = p.max_retries;
  model.solver.calm_frames = p.calm_frames;
  for (std::size_t i = 0; i < model.instruments.size() && i < p.couplings.size(); ++i) {
    model.instruments[i].coupling_stiffness = p.couplings[i].stiffness;
    model.instruments[i].coupling_damping = p.couplings[i].damping;
    model.instruments[i].force_limit = p.couplings[i].force_limit;
  }
}

bool same_materials(const RunTimeParameters& p, const WorldDesc& desc) {
  if (p.materials.size() != desc.segments.size()) return false;
  auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  for (std::size_t s = 0; s < desc.segments.size(); ++s) {
    const MaterialDesc& a = p.materials[s].material;
    const MaterialDesc& b = desc.segments[s].material;
    if (!same(a.youngs_modulus, b.youngs_modulus) || !same(a.poisson_ratio, b.poisson_ratio) ||
        !same(a.density, b.density) || a.response != b.response || !same(a.exp2_alpha, b.exp2_alpha) ||
        !same(a.exp2_beta, b.exp2_beta) || !same(a.exp2_gamma, b.exp2_gamma) ||
        !same(a.failure_strain, b.failure_strain) ||
        !same(p.materials[s].relaxation_time, desc.segments[s].relaxation_time))
      return false;
  }
  return true;
}

}  // namespace haustra::detail
