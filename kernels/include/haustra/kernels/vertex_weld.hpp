#pragma once
// Welding vertices that are one point of a surface held as several meshes (a chain's pieces, each
// skinned on its own cage): each group's copies are set to their mean, so a cut stays closed.
#include <cstdint>
#include <span>

namespace haustra::kernels {

// Groups (CSR): group g's vertices are members[start[g] .. start[g + 1]); start has groups + 1
// entries. Summed in member order, so the result does not depend on threads.
void weld_vertex_groups(std::span<const std::uint32_t> start, std::span<const std::uint32_t> members,
                        std::span<float> x, std::span<float> y, std::span<float> z);

}  // namespace haustra::kernels
