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
  int inside_of = -1;      // the outer piece this lumen lies inside; −1 for an outer wall
  std::size_t source = 0;  // the surface (file) it came from, where several make one scene
};

// Where the open ends of two outer pieces meet.
struct Junction {
  std::size_t a = 0, b = 0;  // pieces
  int loop_a = -1, loop_b = -1;
};

struct OrganLayout {
  std::vector<OrganPiece> pieces;
  std::vector<std::size_t> path;          // outer pieces in order along the organ
  std::vector<int> start_loop, end_loop;  // per path entry: the loop it meets its neighbour at (−1: free)
  std::vector<std::size_t> lumens;        // pieces inside outer pieces on the path
  std::vector<std::size_t> left_out;      // pieces not on the path (side branches, loose pieces)
  // Of several surfaces: outer pieces joined to the path but off it (a flexure's wedge, a branch),
  // also in left_out; skinned with the organ, not followed by its centreline.
  std::vector<std::size_t> joined_off_path;
  [[nodiscard]] std::string text() const;  // "2 shells (outer wall and lumen)", "9 pieces joined ..."
};

// Nesting by the generalized winding number, junctions by open ends (loops at least a quarter as
// long as their piece's longest) whose centres lie within half a radius of each other, the path as
// the longest chain of joined pieces, entering and leaving each piece by different loops.
OrganLayout organ_layout(std::vector<TriangleMesh> pieces);

// Several surfaces' pieces, source[p] the surface of piece p (decision 0094): the same junctions,
// and between pieces of different surfaces also open ends that share points (surfaces cut from one
// segmentation; a wedge cut at a flexure shares its one rim with the pieces on both sides). Organs
// one after another, each the longest chain of joined pieces among the surfaces no organ has taken;
// the surfaces joined to it, on its path or not, are its: the lumens inside its path, and the
// pieces off it (left out, those joined to it skinned with it). Each organ holds its own pieces.
// Ordered by their first surface.
std::vector<OrganLayout> organ_layouts(std::vector<TriangleMesh> pieces, const std::vector<std::size_t>& source);

}  // namespace haustra::import
