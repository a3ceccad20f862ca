#pragma once
// The body around the organs (`haustra import --body`): its boundary read, repaired as a surface is,
// the open ends where a scan stopped closed by a fan each, wound outward — a container the engine
// keeps the beads inside; where its back is (`--gravity supine`); and gravity as asked (decision 0093).
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "haustra/import/import.hpp"
#include "haustra/mesh_io.hpp"

namespace haustra::import {

struct Body {
  TriangleMesh mesh;  // closed, wound outward, metres
  std::string units_reason, repairs;
  std::size_t left_out = 0;  // pieces of the file other than the body's (the largest)
  int capped = 0;            // open ends closed by a fan around their centre
  double volume = 0.0;       // m³
};
// Throws Error naming --body and the file: no triangles, units that cannot be told, a boundary that
// cannot be closed.
Body read_body(const std::filesystem::path& file, const std::string& units);

// The fraction of the organs' vertices (a sample of up to 4,000) outside the body.
double outside_body(const TriangleMesh& body, const std::vector<const TriangleMesh*>& organs);

// Gravity, m/s² in the surfaces' frame: an axis or a vector as given; supine (towards the body's
// back) or prone (its front) from the body and where the organs lie in it. `reason` says which and
// why. Throws Error{invalid_argument} naming --gravity when supine or prone has no body, or the body
// does not tell its back from its front.
Eigen::Vector3d resolve_gravity(const GravityChoice& choice, const Body* body,
                                const std::vector<const TriangleMesh*>& organs, std::string& reason);

}  // namespace haustra::import
