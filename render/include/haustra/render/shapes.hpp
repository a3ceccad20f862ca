#pragma once
// Triangle soups of simple shapes (tubes, spheres, capsules) and a colour map, shared by the
// ray-cast pictures and the interactive viewer.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "haustra/render/image.hpp"

namespace haustra::render {

struct Soup {
  std::vector<Eigen::Vector3d> vertices, normals;  // normals: one per vertex, or none (face normals)
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

Rgb mix(Rgb a, Rgb b, float t);
// A perceptually ordered map from dark blue through green to yellow (viridis-like), t in [0, 1].
Rgb colormap(double t);
// An orthonormal pair across `axis`.
std::pair<Eigen::Vector3d, Eigen::Vector3d> across(const Eigen::Vector3d& axis);

// A tube along a polyline (parallel-transported, so it does not twist).
void add_tube(Soup& g, const std::vector<Eigen::Vector3d>& points, double radius, int sides = 10);
void add_sphere(Soup& g, const Eigen::Vector3d& centre, double radius, int bands = 8);
void add_capsule(Soup& g, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius);

}  // namespace haustra::render
