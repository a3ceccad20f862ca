// Cage rings carried by the rod's stations: their poses, their motion since rest, the cage vertices.
#include "haustra/kernels/cage_rings.hpp"

namespace haustra::kernels {

void ring_poses(RodPoses<const double> rod, std::span<const std::uint32_t> station, std::span<RingPose> out) {
  for (std::size_t g = 0; g < station.size(); ++g) {
    const std::size_t k = station[g] / 2;
    const bool mid = (station[g] & 1U) != 0;
    out[g].centre = mid ? rod.mid_position.get(k) : rod.node_position.get(k);
    out[g].rotation = (mid ? rod.mid_rotation.get(k) : rod.node_rotation.get(k)).toRotationMatrix();
  }
}

void ring_deltas(std::span<const RingPose> rest, std::span<const RingPose> now, std::span<float> out) {
  for (std::size_t g = 0; g < rest.size(); ++g) {
    const Eigen::Matrix3d dr = now[g].rotation - rest[g].rotation;
    const Eigen::Vector3d dc = now[g].centre - rest[g].centre;
    float* d = out.data() + kRingDeltaFloats * g;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d[4 * r + c] = static_cast<float>(dr(r, c));
      d[4 * r + 3] = static_cast<float>(dc[r]);
    }
  }
}

void gpu_ring_frame(std::span<const RingPose> rest, std::span<const RingPose> now, std::span<float> out) {
  for (std::size_t g = 0; g < rest.size(); ++g) {
    float* d = out.data() + kGpuRingFloats * g;
    ring_deltas(rest.subspan(g, 1), now.subspan(g, 1), std::span<float>(d, kRingDeltaFloats));
    const Eigen::Matrix3d carry = (now[g].rotation - rest[g].rotation) * rest[g].rotation.transpose();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) d[kRingDeltaFloats + 4 * r + c] = static_cast<float>(carry(r, c));
      d[kRingDeltaFloats + 4 * r + 3] = 0.0f;
    }
  }
}

void cage_vertices(std::span<const RingPose> rings, std::span<const std::uint32_t> vertex_ring,
                   std::span<const Eigen::Vector3d> offset, std::span<Eigen::Vector3d> out) {
  for (std::size_t j = 0; j < vertex_ring.size(); ++j) {
    const RingPose& r = rings[vertex_ring[j]];
    out[j] = r.centre + r.rotation * offset[j];
  }
}

}  // namespace haustra::kernels
