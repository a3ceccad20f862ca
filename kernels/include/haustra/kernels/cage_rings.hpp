#pragma once
// Cage rings follow the rod. A ring is a cross-section template carried rigidly by one station of
// the rod: a node (station 2k) or the midpoint of section k (station 2k + 1). Every cage vertex is
// a fixed offset in its ring's frame, so the cage moves with rotations only and keeps its radial
// distances (the paper's answer to the collapsing joint of linear-blend skinning).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <span>

#include "haustra/kernels/spans.hpp"

namespace haustra::kernels {

struct RingPose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // ring frame to world (d1 d2 d3)
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};

inline constexpr std::size_t kRingDeltaFloats = 12;  // 3×4 row-major [R' − R | c' − c]

// The pose of each ring's station: node k for station 2k, the midpoint of section k for 2k + 1.
void ring_poses(RodPoses<const double> rod, std::span<const std::uint32_t> station, std::span<RingPose> out);

// How each ring moved from its rest pose, as the 3×4 matrix [R' − R | c' − c] in float: what the
// skinning kernels apply (x' = x + Σ_g [ΔR_g A_g + b_g Δc_g]). At rest it is exactly zero.
void ring_deltas(std::span<const RingPose> rest, std::span<const RingPose> now, std::span<float> out);

// What a vertex shader reads per ring to skin on a host's GPU (docs/skinning.md, "Skinning on the
// host's GPU"): kGpuRingFloats floats, as six rows of four — rows 0–2 the same floats as
// ring_deltas ([R' − R | c' − c]), rows 3–5 [(R' − R) Rᵀ | 0] (R the rest rotation), what carries a
// vertex's rest normal: Σ_g b_g (R'_g − R_g) R_gᵀ + I is the rings' rotations blended by weight.
inline constexpr std::size_t kGpuRingFloats = 24;
void gpu_ring_frame(std::span<const RingPose> rest, std::span<const RingPose> now, std::span<float> out);

// Cage vertex positions: p_j = c_g + R_g o_j for the ring g of vertex j.
void cage_vertices(std::span<const RingPose> rings, std::span<const std::uint32_t> vertex_ring,
                   std::span<const Eigen::Vector3d> offset, std::span<Eigen::Vector3d> out);

}  // namespace haustra::kernels
