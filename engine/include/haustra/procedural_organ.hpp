#pragma once
// A procedural colon/rectum: a closed triangle tube around a rod curve, so that a scene needs no
// downloaded asset. Rings of vertices in each pose's (d1, d2) plane, with haustral folds at regular
// spacing, the three taeniae coli as shallow longitudinal grooves, and rounded, closed ends.
#include "haustra/mesh_io.hpp"
#include "haustra/rod_curve.hpp"
#include "haustra/world_desc.hpp"

namespace haustra {

// Throws Error{invalid_argument} naming `where` and the field for out-of-range parameters.
TriangleMesh procedural_organ(const RodCurve& curve, const ProceduralOrganDesc& desc, double default_radius,
                              const std::string& where = "mesh.procedural");

}  // namespace haustra
