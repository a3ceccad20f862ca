#pragma once
// The localization study of docs/skinning.md: how many rings each mesh vertex keeps (K) against
// what it costs and how far the mesh lands from full mean value coordinates, over extreme rod
// poses, with linear-blend skinning beside it (the paper's Fig. 6b: the collapsing joint).
#include <string>
#include <vector>

#include "haustra/mesh_io.hpp"
#include "haustra/world.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::validation {

struct SkinningStudyRow {
  std::string method;        // "MVC, K = 4", "MVC, all rings", "linear blend"
  int rings_per_vertex = 0;  // 0: all
  double slots = 0.0;        // rings per vertex actually stored (mean over the vertices)
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
};

struct SkinningStudy {
  std::string organ;  // what was posed
  std::size_t vertices = 0, rings = 0;
  double mesh_size = 0.0;  // m, bounding-box diagonal
  std::vector<std::string> poses;
  std::vector<SkinningStudyRow> rows;
  double transport_bend_volume_change = 0.0, transport_twist_volume_change = 0.0;
};

SkinningStudy run_skinning_study();

// The study's organ (a straight procedural rectum, 30 cm, 11 beads, 10,000 vertices) with the
// given skinning, and its poses (node strains, 4 per node; the first is the 90° bend).
// weight_left_out: 0 keeps exactly rings_per_vertex (the K sweep).
WorldDesc study_organ(SkinningMethod method, int rings_per_vertex, double weight_left_out = 0.0);
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

}  // namespace haustra::validation
