#pragma once
// The many-segment benchmarks' world: rows of `drop`-sized rods (1 m, 167 nodes, 55 beads of 2 cm)
// lying side by side on a floor 1 mm further apart than their beads are wide, 16 to a row, so
// neighbours touch as they settle; optionally a procedural organ mesh on each.
#include <string>

#include "haustra/world_desc.hpp"

namespace haustra::bench {

inline WorldDesc segment_rows(std::size_t count, int threads, int mesh_vertices = 0) {
  WorldDesc d;
  d.threads = threads;
  PlaneDesc floor;
  floor.name = "floor";
  d.environment.planes.push_back(floor);
  const std::size_t per_row = 16;
  for (std::size_t i = 0; i < count; ++i) {
    SegmentDesc s;
    s.name = "segment" + std::to_string(i);
    s.rest.length = 1.0;
    s.base_position = {1.1 * static_cast<double>(i / per_row), 0.041 * static_cast<double>(i % per_row), 0.0202};
    s.beads.enabled = true;
    s.beads.count = 55;
    s.beads.radius = 0.02;
    if (mesh_vertices > 0) {
      s.mesh.enabled = true;
      s.mesh.procedural.vertices = mesh_vertices;
    }
    d.segments.push_back(s);
  }
  return d;
}

}  // namespace haustra::bench
