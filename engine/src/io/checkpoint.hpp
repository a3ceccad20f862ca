#pragma once
// A world's state as bytes, and back: what a frame carries over to the next one, so that stepping
// on from a restored checkpoint gives the same bits as never having stopped.
// Format (docs/decisions/0026-checkpoints.md): magic, format version, the model's counts and
// fingerprint, the payload, an FNV-1a checksum of the payload.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "model/world_model.hpp"
#include "step/world_state.hpp"

namespace haustra::detail {

[[nodiscard]] std::vector<std::byte> save_checkpoint(const WorldModel& model, const WorldState& state);

// Checks the whole checkpoint (header, model, checksum, sizes, finite values, indices) before it
// writes anything: a refused checkpoint leaves the state as it was. `source` names it in errors.
// Derived buffers (mesh, frame-start snapshot) are left to the caller to rebuild.
void restore_checkpoint(const WorldModel& model, WorldState& state, std::span<const std::byte> bytes,
                        const std::string& source);

}  // namespace haustra::detail
