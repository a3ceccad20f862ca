#pragma once
// The skin choice of docs/skinning.md (decision 0120): each of mesh.skinning's values against what
// it costs and how far the mesh lands from rigid cross-sections and from full mean value
// coordinates, over extreme rod poses, with linear-blend skinning beside it (the paper's Fig. 6b).
#include <string>
#include <vector>

#include "haustra/mesh_io.hpp"
#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::validation {

struct SkinningStudyRow {
  std::string method;  // the scene's value and what it is
  SkinningMethod skinning = SkinningMethod::along_rod;
  double slots = 0.0;             // rings per vertex actually stored (mean over the vertices)
  double slots_per_vertex = 0.0;  // what skinning reads: blocks' slots, padding included (the cost)
  double bytes_per_vertex = 0.0;
  double skin_us = 0.0;     // median skinning time per frame, µs
  double rest_error = 0.0;  // m, max over vertices
  double max_error = 0.0;   // m, against full MVC over the posed frames
  double p99_error = 0.0;   // m
  // m, against carrying each vertex rigidly with the rod's frame at its own arc length (what a
  // tube whose cross-sections stay rigid and square to the centreline does)
  double transport_max = 0.0, transport_p99 = 0.0;
  double bend_volume_change = 0.0;   // relative, 90° bend
  double twist_volume_change = 0.0;  // relative, 90° twist
  double mean_dropped_mass = 0.0;
  double worst_edge_stretch = 0.0;  // the longest edge over its rest length, over the poses (the rod does not stretch)
};

struct SkinningStudy {
  std::string organ;  // what was posed
  std::size_t vertices = 0, rings = 0;
  double mesh_size = 0.0;  // m, bounding-box diagonal
  std::vector<std::string> poses;
  std::vector<SkinningStudyRow> rows;
  double transport_bend_volume_change = 0.0, transport_twist_volume_change = 0.0;
  double transport_worst_edge = 0.0;  // the rigid cross-sections' own: the outer wall of a tight bend stretches
};

SkinningStudy run_skinning_study();

// The study's organ (a straight procedural rectum, 30 cm, 11 beads, 10,000 vertices) with the
// given skinning, and its poses (node strains, 4 per node; the first is the 90° bend).
WorldDesc study_organ(SkinningMethod method);
struct StudyPose {
  std::string name;
  std::vector<double> strain;
};
std::vector<StudyPose> study_poses();
std::string skinning_markdown(const SkinningStudy& study);

// Seconds the skin stage takes to bring w's organ meshes up to its current pose: the mesh is made
// when read (decision 0060), so this reads it and takes that stage's share of the profile. 0 when
// the meshes were already read at this pose.
double skinning_seconds(const World& w);

// The first segment's organ mesh as it is now, and with its vertices at x (its own triangles).
std::vector<Eigen::Vector3d> organ_points(const World& w);
TriangleMesh organ_mesh(const World& w, const std::vector<Eigen::Vector3d>& x);

// The longest edge of `mesh` at positions x over its length at mesh's own positions (1: none stretched).
double worst_edge_stretch(const TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& x);

}  // namespace haustra::validation
