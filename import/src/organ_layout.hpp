#pragma once
// What a repaired surface holds: outer walls and the lumens nested inside them (an organ modelled
// with a wall of two shells), and the order of the outer pieces along the organ where a whole organ
// comes as pieces whose open ends meet (an atlas's segments).
#include <cstddef>
#include <string>
#include <vector>

#include "haustra/mesh_io.hpp"

namespace haustra::import {

struct OrganPiece {
  TriangleMesh mesh;
  std::vector<std::vector<std::uint32_t>> loops;  // boundary loops, each in order
  double area = 0.0;
  int inside_of = -1;  // the outer piece this lumen lies inside; −1 for an outer wall
};

// Where the open ends of two outer pieces meet.
struct Junction {
  std::size_t a = 0, b = 0;  // pieces
  int loop_a = -1, loop_b = -1;
};

struct OrganLayout {
  std::vector<OrganPiece> pieces;
  std::vector<std::size_t> path;           // outer pieces in order along the organ
  std::vector<int> start_loop, end_loop;   // per path entry: the loop it meets its neighbour at (−1: free)
  std::vector<std::size_t> lumens;         // pieces inside outer pieces on the path
  std::vector<std::size_t> left_out;       // pieces not on the path (side branches, loose pieces)
  [[nodiscard]] std::string text() const;  // "2 shells (outer wall and lumen)", "9 pieces joined ..."
};

// Nesting by ray parity (a point inside a tube's wall crosses it an odd number of times in most
// directions), junctions by loops whose centres lie within half a radius of each other, the path
// as the longest chain of joined pieces.
OrganLayout organ_layout(std::vector<TriangleMesh> pieces);

}  // namespace haustra::import
