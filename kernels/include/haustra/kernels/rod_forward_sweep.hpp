#pragma once
// Forward sweep: node and section-midpoint poses from the base pose and the node strains.
// Section k (length h_k) carries the constant strain ξ_k = ½(q_k + q_{k+1}); its pose update is the
// exact SE(3) exponential, taken as two equal halves so the midpoint pose comes for free:
// g_mid = g_k · exp(½h_k ξ̂_k), g_{k+1} = g_mid · exp(½h_k ξ̂_k). Arcs and helices are exact at any N.
#include <span>

#include "haustra/kernels/pose.hpp"
#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

// section_length: N values (h_0 … h_{N−1}); strain: N+1 nodes; out: N+1 nodes, N midpoints.
// A block of sections' exponentials is computed first (series to 0.5 rad a half section, closed
// forms past it; decision 0125), then the poses composed; no allocation.
void rod_forward_sweep(const Pose& base, std::span<const double> section_length, StrainView<const double> strain,
                       RodPoses<double> out);

// Reference: the same map through the 4×4 matrix exponential of each section's twist (Eigen's
// MatrixFunctions), with no closed forms, quaternions or half steps shared with the fast path.
void rod_forward_sweep_reference(const Pose& base, std::span<const double> section_length,
                                 StrainView<const double> strain, RodPoses<double> out);

}  // namespace haustra::kernels
