#pragma once
// Every surface of a folder imported with the defaults and put through the same test: 120 frames
// with both ends held and a grasper closed on the middle node lifting it 2 cm; per surface what
// the import did and found, and what the run measured (docs/anatomy.md, `make anatomy`).
#include <filesystem>
#include <string>
#include <vector>

#include "haustra/import/import.hpp"

namespace haustra::import {

// Frames each surface runs for after its import (docs/anatomy.md: 2 s at 60 Hz).
inline constexpr int kCohortFrames = 120;

struct CohortRow {
  std::string name;
  bool imported = false, ran = false;
  std::string error;                                         // the import's or the run's message, first line
  ImportReport report;                                       // what the import found (valid when imported)
  std::size_t mesh_vertices = 0, outside = 0, crossing = 0;  // binding pose: vertices outside the cage, edges across it
  int frames = 0;
  bool finite = false;
  std::size_t recovered = 0, unstable = 0;  // events: frames redone by the robust mode, frames that failed
  bool grasped = false;                     // the grasper still held a node at the end
  double lift = 0.0;                        // m the grasped node rose
  double skin_error = 0.0;                  // m: localized skinning against full MVC of the same cage, after the lift
  // What skinning costs per vertex (slots, padding included) against fixed K = 4 on the same cages:
  // the whole organ, and its worst piece.
  double skin_cost = 0.0, skin_cost_worst = 0.0;
  double frame_median = 0.0, frame_p99 = 0.0;  // s per frame, the mesh included, on the row's threads
};

// One surface: imported into `out` (a folder of its own), then run on `threads` threads (the
// table's are 2; a study's import runs on its cells' threads). Never throws: a failure is the
// row's error.
CohortRow run_cohort_surface(const std::filesystem::path& surface, const std::filesystem::path& out,
                             int frames = kCohortFrames, int threads = 2);

// Every .obj of `folder`, in name order.
std::vector<CohortRow> run_cohort(const std::filesystem::path& folder, const std::filesystem::path& out,
                                  int frames = kCohortFrames, int threads = 2);

// docs/anatomy.md: generated, dated, the machine named.
std::string cohort_markdown(const std::vector<CohortRow>& rows, const std::filesystem::path& folder);

}  // namespace haustra::import
