#pragma once
// Skinning quality on real anatomy (docs/skinning.md): every real segment and procedural organs
// imported as a user would (`haustra import`), deformed (rest, a 90° bend, a grasp-and-lift, a
// rigid motion), skinned along the rod and with the cage (decision 0120's choices), each against
// full mean value coordinates of the same cage ("cage-full") and against rigid cross-sections.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace haustra::import {

struct AnatomyRow {
  std::string organ, skin;
  std::size_t vertices = 0, rings = 0;
  double slots_per_vertex = 0.0;                 // what skinning reads (blocks' padding included)
  double worst_edge_stretch = 0.0;               // the longest edge over its rest length, over the deformations
  double skin_us = 0.0;                          // the skin stage on one thread, median
  std::vector<double> max_error, p99_error;      // m against full MVC, per deformation
  double rigid_max = 0.0, rigid_p99 = 0.0;       // m against rigid cross-sections, over the deformations
  double volume_change = 0.0;                    // relative, in the 90° bend (closed meshes; NaN when open)
  double rest_correction = 0.0, left_out = 0.0;  // worst vertex
};

struct AnatomyStudy {
  std::vector<std::string> deformations;
  std::vector<AnatomyRow> rows;
};

// The organs of docs/skinning.md's real-anatomy table, imported into `work` with the defaults: the
// CT colon (assets/large-intestine-A-DSJ*) with its midline and without, and procedural organs
// (straight; bent at 1.2 radii; a loop touching itself). (name, scene file) pairs.
std::vector<std::pair<std::string, std::filesystem::path>> import_study_organs(const std::filesystem::path& assets,
                                                                               const std::filesystem::path& work);

// organs: (name, scene file) pairs, scenes as `haustra import` writes them.
AnatomyStudy run_anatomy_study(const std::vector<std::pair<std::string, std::filesystem::path>>& organs);
std::string anatomy_markdown(const AnatomyStudy& study);

// A procedural organ (radius 20 mm, 12,000 vertices) along pieces of constant (κ1, κ2, τ) of the
// given lengths, written as a mesh file scaled by `scale` (1000: millimetres): test and study input.
void write_procedural_organ(const std::filesystem::path& file,
                            const std::vector<std::pair<double, Eigen::Vector3d>>& pieces, double scale);

}  // namespace haustra::import
