#pragma once
// Every surface of a folder imported with the defaults and put through the organ protocol (decision
// 0097): left alone, then grasped, pulled 5 cm sideways, held, released and left alone again; per
// surface what the import found and what the organ did (docs/anatomy.md, `make anatomy`).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "haustra/import/import.hpp"
#include "haustra/scene.hpp"

namespace haustra::import {

// The protocol's phases, s (docs/anatomy.md's; the tests run shorter ones).
struct OrganProtocol {
  double rest = 10.0;      // left alone
  double pull = 1.0;       // grasped and pulled 5 cm sideways
  double hold = 1.0;       // held there
  double after = 3.0;      // released, left alone
  double distance = 0.05;  // m, sideways
  double along = 0.5;      // where the grasper takes the longest organ: a fraction of its nodes from its base
  int threads = 2;
  // The skin each organ's mesh is bound with (decision 0117); unset: the imported scene's own.
  std::optional<SkinningMethod> skinning;
};

struct CohortRow {
  std::string name;
  bool imported = false, ran = false, holds = false;
  std::string error;                           // the import's or the run's message, first line
  ImportReport report;                         // what the import found (valid when imported)
  std::size_t mesh_vertices = 0, outside = 0;  // binding pose: vertices outside the cage
  int frames = 0;
  std::size_t recovered = 0, unstable = 0, torn = 0;  // events: frames redone, frames that failed, anchors torn
  bool slipped = false;  // the grasp let go: pulled past its holding force, or the wall past its failure strain
  // Left alone: how far the mesh's vertices went from where the segmentation put them (m), the
  // median vertex and the farthest, the largest over the phase.
  double rest_median = 0.0, rest_max = 0.0;
  bool grasped = false;                        // the grasper took hold
  double largest_force = 0.0;                  // N, reported for the grasper over the pull, the hold and the release
  double force_limit = 0.0;                    // N, the grasper's
  double pulled = 0.0;                         // m the grasped node moved sideways by the end of the hold
  double after_median = 0.0, after_max = 0.0;  // m from where the segmentation put them, at the end
  // The skin: the largest ratio of a mesh edge's length to its rest length, over the rod's own
  // stretch where it is (decision 0121), over the run, and how many edges passed twice that at some
  // measure; the same while left alone (the rest phase); and the largest ratio not divided by the rod's.
  double stretch_worst = 0.0;
  double stretch_raw = 0.0;
  std::size_t stretch_edges = 0;
  double stretch_rest_worst = 0.0;
  std::size_t stretch_rest_edges = 0;
  double skin_slots = 0.0;  // what skinning reads per mesh vertex: its binding's slots (decision 0117)
  int frames_late = 0;      // frames (with the mesh) over the frame's dt
  double frame_median = 0.0, frame_p99 = 0.0;  // s per frame, the mesh included
};

// The scene with the protocol's grasper (its instruments replaced by it).
SceneDesc with_protocol_grasper(SceneDesc scene, const OrganProtocol& protocol = {});

// A scene put through the protocol: its world built from `scene`, on the protocol's threads; the
// grasper added 3 cm above the middle of the centreline. Never throws: a failure is the row's error.
CohortRow run_protocol(const SceneDesc& scene, const std::string& name, const OrganProtocol& protocol = {});

// One surface imported into `out` (a folder of its own), then put through the protocol.
CohortRow run_cohort_surface(const std::filesystem::path& surface, const std::filesystem::path& out,
                             const OrganProtocol& protocol = {});

// Every .obj of `folder`, in name order.
std::vector<CohortRow> run_cohort(const std::filesystem::path& folder, const std::filesystem::path& out,
                                  const OrganProtocol& protocol = {});

// An abdomen: every .obj of `folder` whose name starts with `prefix`, and `body` around them,
// imported as one scene (decision 0094) into `out` and put through the protocol (the grasper on the
// middle of its longest organ). Never throws: a failure is the row's error.
CohortRow run_abdomen(const std::filesystem::path& folder, const std::string& prefix, const std::filesystem::path& body,
                      const std::filesystem::path& out, const OrganProtocol& protocol = {});

// docs/anatomy.md: generated, dated, the machine named.
std::string cohort_markdown(const std::vector<CohortRow>& rows, const std::filesystem::path& folder,
                            const OrganProtocol& protocol = {});

}  // namespace haustra::import
