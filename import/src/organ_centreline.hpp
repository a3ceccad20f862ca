#pragma once
// The centreline of an organ's outer wall: each piece on its path given its axis (the area
// centroids of a harmonic function's level sets, haustra/tube_axis.hpp), joined in order, pulled
// back from closed ends by the tube's radius, smoothed. Deterministic: the same surface gives the
// same points, bit for bit.
#include <string>
#include <vector>

#include "centreline_fit.hpp"
#include "organ_layout.hpp"

namespace haustra::import {

struct OrganCentreline {
  Polyline points;           // from the start to the end, about 1 mm apart
  int open_ends = 0;         // of the organ's two ends (0, 1 or 2)
  int capped_loops = 0;      // side openings and holes capped for the solves
  double pulled_back = 0.0;  // m taken off at closed ends
  double folded = 0.0;       // m left out where the wall folds back inside itself
  bool reversed = false;     // the wider end was at the far end: the line runs from it
  std::string text;          // for the report
};

// `reverse` runs the line the other way round after choosing (the base is the wider open end).
OrganCentreline organ_centreline(const OrganLayout& layout, bool reverse);

}  // namespace haustra::import
