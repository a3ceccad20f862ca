#pragma once
// The files an import writes beside its scene: the repaired surface (OBJ, metres), the centreline
// (JSON, metres) and the scene (TOML) that points at both.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "centreline_fit.hpp"
#include "haustra/import/import.hpp"
#include "haustra/mesh_io.hpp"

namespace haustra::import {

// The pieces as one mesh, with no two vertices at the same position (in float, as a reader that
// joins identical vertices sees them): a point the repair split in two (a pinch, an edge of three
// triangles) is moved a millionth of the mesh's size towards its own triangles.
TriangleMesh joined_apart(const std::vector<const TriangleMesh*>& pieces);

void write_obj(const std::filesystem::path& file, const TriangleMesh& mesh, const std::string& comment);
void write_centreline(const std::filesystem::path& file, const Polyline& p, const std::string& source);

struct SceneFileInputs {
  const ImportOptions& options;
  const ImportReport& report;
  std::vector<std::pair<double, double>> radius_profile;  // (fraction of the length, m)
};
void write_scene(const SceneFileInputs& in);

// Several organs and the body around them: per organ its options (its name and ends) and radius profile.
struct SurfacesSceneInputs {
  std::string command;  // the surfaces and options, as the header names them
  const std::vector<ImportOptions>& options;
  const SurfacesReport& report;
  const std::vector<std::vector<std::pair<double, double>>>& radius_profiles;
};
void write_surfaces_scene(const SurfacesSceneInputs& in);

}  // namespace haustra::import
