#pragma once
// The paper's inertia filter (eq. 11–12): blends each node's estimated position with its previous
// one, the more the heavier the node and the larger the frame's largest displacement Δr:
//   a_k = exp(−ζ m_k Δr / Δt²),  r_k = a_k r̃_k + (1 − a_k) r_k^{t−1}.
// Per node and uncoupled. Section midpoints move by the mean of their two nodes' corrections, so
// the lever arms of the next backward sweep match the filtered nodes.
#include <cstdint>
#include <span>

#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

// exempt[k] != 0 keeps node k as estimated (clamped base, attached nodes).
// Returns Δr, the largest distance between estimated and previous positions.
double inertia_filter(Vec3View<const double> previous, std::span<const double> node_mass,
                      std::span<const std::uint8_t> exempt, double zeta, double dt, Vec3View<double> node_position,
                      Vec3View<double> mid_position);

}  // namespace haustra::kernels
