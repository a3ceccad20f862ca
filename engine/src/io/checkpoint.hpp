#pragma once
// A world's state as bytes, and back: what a frame carries over to the next one, so that stepping
// on from a restored checkpoint gives the same bits as never having stopped.
// Format (docs/decisions/0026-checkpoints.md, 0099): magic, format version, the model's counts and
// fingerprint, the payload (the run-time parameters, then the state), an FNV-1a checksum of it.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "haustra/world_desc.hpp"
#include "model/world_model.hpp"
#include "state/world_state.hpp"

namespace haustra::detail {

// What the run-time setters change between frames without touching the state's layout (decision
// 0099): gravity, dt, the frame's budget and limits, each instrument's coupling, each segment's
// material. A checkpoint carries them; restoring one puts them back.
struct RunTimeParameters {
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  double dt = 0.0;
  double frame_budget = 0.0;
  int max_substeps = 1, max_retries = 0, calm_frames = 1;
  struct Coupling {
    double stiffness, damping, force_limit;
  };
  std::vector<Coupling> couplings;  // per instrument
  struct Material {
    MaterialDesc material;
    double relaxation_time;
  };
  std::vector<Material> materials;  // per segment of the description (a chain's, once)
};

[[nodiscard]] RunTimeParameters parameters_of(const WorldDesc& desc);
// Into a description, and into the model's copies of them (dt, gravity, solver limits, couplings;
// a material needs a rebuild of the rods).
void apply_parameters(const RunTimeParameters& p, WorldDesc& desc);
void apply_parameters(const RunTimeParameters& p, WorldModel& model);
// Whether every segment's material and relaxation time are the same, bit for bit.
[[nodiscard]] bool same_materials(const RunTimeParameters& p, const WorldDesc& desc);

[[nodiscard]] std::vector<std::byte> save_checkpoint(const WorldModel& model, const WorldState& state,
                                                     const RunTimeParameters& parameters);

// A checkpoint whose header, sizes and checksum were checked against a world, and its run-time
// parameters read: what restoring needs before it chooses the model to restore into.
struct OpenedCheckpoint {
  RunTimeParameters parameters;
  std::uint64_t fingerprint = 0;
  std::span<const std::byte> state;  // the rest of the payload
};
// Error{parse} naming `source` when the bytes are not a checkpoint of a world of this one's sizes.
[[nodiscard]] OpenedCheckpoint open_checkpoint(const WorldModel& model, const WorldDesc& desc,
                                               std::span<const std::byte> bytes, const std::string& source);

// The state of an opened checkpoint into `state`, once the whole of it checks against `model` (which
// holds the checkpoint's parameters: its rod must give the same fingerprint) — sizes, finite values,
// indices; otherwise Error{parse} and the state as it was. Derived buffers (mesh, frame-start
// snapshot) are left to the caller to rebuild.
void restore_state(const WorldModel& model, WorldState& state, const OpenedCheckpoint& checkpoint,
                   const std::string& source);

}  // namespace haustra::detail
