// The real-anatomy skinning table: imported organs, four deformations, along the rod and the cage,
// each against full MVC ("cage-full") and against rigid cross-sections.
#include "haustra/studies/anatomy_study.hpp"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <tuple>

#include "haustra/import/import.hpp"
#include "haustra/mesh_io.hpp"
#include "haustra/procedural_organ.hpp"
#include "haustra/rod_curve.hpp"
#include "haustra/scene.hpp"
#include "haustra/studies/skinning_study.hpp"
#include "haustra/world.hpp"

namespace haustra::import {
namespace {

using Points = std::vector<Eigen::Vector3d>;

// Rigid cross-sections: each vertex at its rest arc length s (nearest point of the rest centreline,
// sampled every 0.5 mm) and offset o in the rod's frame there, carried by the posed rod.
struct Material {
  std::vector<double> s;
  Points o;
};

RodCurve curve_of(const World& w, std::span<const double> strain, const kernels::Pose& base) {
  const auto h = w.section_lengths();
  return RodCurve(std::span<const double>(h.data(), w.node_count() - 1), strain, base);
}

Material material(const World& w, const Points& rest) {
  const auto q = w.rest_strains().data;
  const RodCurve curve = curve_of(w, q, w.base_pose(0));
  std::vector<double> arcs;
  Points centres;
  for (double s = 0.0; s <= curve.length(); s += 5e-4) {
    arcs.push_back(s);
    centres.push_back(curve.pose_at(s).position);
  }
  Material m;
  for (const auto& x : rest) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < centres.size(); ++i)
      if ((centres[i] - x).squaredNorm() < (centres[best] - x).squaredNorm()) best = i;
    const kernels::Pose p = curve.pose_at(arcs[best]);
    m.s.push_back(arcs[best]);
    m.o.push_back(p.rotation.conjugate() * (x - p.position));
  }
  return m;
}

Points carried(const World& w, const Material& m) {
  const auto q = w.strains().data;
  const RodCurve curve = curve_of(w, q, w.base_pose(0));
  Points out;
  for (std::size_t i = 0; i < m.s.size(); ++i) {
    const kernels::Pose p = curve.pose_at(m.s[i]);
    out.push_back(p.position + p.rotation * m.o[i]);
  }
  return out;
}

double volume_of(const World& w, const Points& x) {
  const TriangleMesh m = validation::organ_mesh(w, x);
  return mesh_volume(m.vertices, m.triangles);
}

std::pair<double, double> max_p99(std::vector<double> e) {
  if (e.empty()) return {0.0, 0.0};
  std::sort(e.begin(), e.end());
  return {e.back(), e[static_cast<std::size_t>(0.99 * static_cast<double>(e.size() - 1))]};
}

// The deformations, applied to one world: each leaves it in its posed state.
const std::vector<std::string> kDeformations = {"rest", "90° bend", "grasp and lift", "rigid motion"};

void deform(World& w, std::size_t which) {
  const auto rest = w.rest_strains().data;
  std::vector<double> q(rest.begin(), rest.end());
  const std::size_t n = w.node_count();
  const kernels::Pose base = w.base_pose(0);
  switch (which) {
    case 0: w.pose_rod(0, base, q); break;
    case 1: {  // κ1 added over the middle fifth, 90° in all
      double length = 0.0;
      for (double h : w.section_lengths().subspan(0, n - 1)) length += h;
      const double kappa = 0.5 * std::numbers::pi / (0.2 * length);
      double s = 0.0;
      for (std::size_t k = 0; k < n; ++k) {
        if (s > 0.4 * length && s < 0.6 * length) q[4 * k] += kappa;
        if (k + 1 < n) s += w.section_lengths()[k];
      }
      w.pose_rod(0, base, q);
      break;
    }
    case 2: {  // held at both ends (the scene's), the middle pulled up by 3 N for a second
      w.pose_rod(0, base, q);
      w.set_external_load(n / 2, Eigen::Vector3d(0.0, 0.0, 3.0), Eigen::Vector3d::Zero());
      for (int f = 0; f < 60; ++f) w.step();
      w.set_external_load(n / 2, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
      break;
    }
    default: {  // 60° about a tilted axis and 10 cm aside
      kernels::Pose moved = base;
      const Eigen::Quaterniond turn(Eigen::AngleAxisd(std::numbers::pi / 3.0, Eigen::Vector3d(1, 1, 0).normalized()));
      moved.rotation = turn * base.rotation;
      moved.position = base.position + Eigen::Vector3d(0.1, 0.0, 0.05);
      w.pose_rod(0, moved, q);
    }
  }
}

}  // namespace

void write_procedural_organ(const std::filesystem::path& file,
                            const std::vector<std::pair<double, Eigen::Vector3d>>& pieces, double scale) {
  constexpr double h = 0.002;
  std::vector<double> sections, strains;
  for (const auto& [length, k] : pieces) {
    const int n = std::max(1, static_cast<int>(std::round(length / h)));
    for (int i = 0; i < n; ++i) {
      sections.push_back(length / n);
      strains.insert(strains.end(), {k.x(), k.y(), k.z(), 0.0});
    }
  }
  strains.insert(strains.end(), {0.0, 0.0, 0.0, 0.0});
  const RodCurve curve(sections, strains, kernels::Pose{});
  ProceduralOrganDesc d;
  d.vertices = 12'000;
  TriangleMesh mesh = procedural_organ(curve, d, 0.02);
  for (auto& v : mesh.vertices) v *= scale;
  save_mesh(file, mesh);
}

std::vector<std::pair<std::string, std::filesystem::path>> import_study_organs(const std::filesystem::path& assets,
                                                                               const std::filesystem::path& work) {
  namespace fs = std::filesystem;
  fs::create_directories(work);
  const fs::path colon = assets / "large-intestine-A-DSJ.obj",
                 midline = assets / "large-intestine-A-DSJ-centreline.json";
  const double bend = 1.0 / (1.2 * 0.02), R = 0.05, c = 0.042 / (2.0 * std::numbers::pi);
  write_procedural_organ(work / "straight.obj", {{0.3, Eigen::Vector3d::Zero()}}, 1000.0);
  write_procedural_organ(work / "tight-bend.obj",
                         {{0.12, Eigen::Vector3d::Zero()},
                          {std::numbers::pi / bend, Eigen::Vector3d(bend, 0, 0)},
                          {0.12, Eigen::Vector3d::Zero()}},
                         1000.0);
  write_procedural_organ(work / "touching-loop.obj",
                         {{0.1, Eigen::Vector3d::Zero()},
                          {2.0 * std::numbers::pi * std::sqrt(R * R + c * c),
                           Eigen::Vector3d(R / (R * R + c * c), 0, c / (R * R + c * c))},
                          {0.1, Eigen::Vector3d::Zero()}},
                         1000.0);
  const std::vector<std::tuple<std::string, fs::path, fs::path, std::string>> list = {
      {"CT rectum and sigmoid (A-DSJ), its CT midline", colon, midline, "colon-midline"},
      {"CT rectum and sigmoid (A-DSJ), computed centreline", colon, {}, "colon-computed"},
      {"procedural, straight 30 cm", work / "straight.obj", {}, "straight"},
      {"procedural, bent at 1.2 radii", work / "tight-bend.obj", {}, "tight-bend"},
      {"procedural, a loop touching itself", work / "touching-loop.obj", {}, "touching-loop"}};
  std::vector<std::pair<std::string, fs::path>> out;
  for (const auto& [name, mesh, line, stem] : list) {
    ImportOptions o;
    o.mesh = mesh;
    o.centreline = line;
    o.out = work / (stem + ".toml");
    out.emplace_back(name, import_surface(o).scene);
  }
  return out;
}

AnatomyStudy run_anatomy_study(const std::vector<std::pair<std::string, std::filesystem::path>>& organs) {
  AnatomyStudy study{kDeformations, {}};
  struct Variant {
    const char* name;
    SkinningMethod skinning;
  };
  const Variant variants[] = {{"`\"along-rod\"` (default)", SkinningMethod::along_rod},
                              {"`\"cage\"`", SkinningMethod::cage},
                              {"`\"cage-full\"` (the reference)", SkinningMethod::cage_full}};
  for (const auto& [name, scene_file] : organs) {
    SceneDesc scene = load_scene(scene_file);
    scene.world.threads = 1;
    scene.world.instruments.clear();
    std::vector<std::unique_ptr<World>> worlds;
    for (const Variant& v : variants) {
      SceneDesc s = scene;
      s.world.segments[0].mesh.skinning = v.skinning;
      s.world.segments[0].mesh.normals = false;
      worlds.push_back(create_world(s));
    }
    const Points rest = validation::organ_points(*worlds.back());
    const Material mat = material(*worlds.back(), rest);
    const TriangleMesh rest_mesh = validation::organ_mesh(*worlds.back(), rest);
    const bool closed = is_closed(rest_mesh);
    std::vector<std::vector<Points>> posed(worlds.size());
    std::vector<std::vector<double>> times(worlds.size());
    std::vector<Points> rigid;
    for (std::size_t d = 0; d < kDeformations.size(); ++d)
      for (std::size_t v = 0; v < worlds.size(); ++v) {
        deform(*worlds[v], d);
        if (d != 2) times[v].push_back(validation::skinning_seconds(*worlds[v]));
        posed[v].push_back(validation::organ_points(*worlds[v]));
        if (v + 1 == worlds.size()) rigid.push_back(carried(*worlds[v], mat));
      }
    const double rest_volume = volume_of(*worlds.back(), rest);
    for (std::size_t v = 0; v + 1 < worlds.size(); ++v) {
      const MeshInfo& info = worlds[v]->mesh(0);
      AnatomyRow row;
      row.organ = name;
      row.skin = variants[v].name;
      row.vertices = info.vertices.count;
      row.rings = info.cage.rings;
      row.slots_per_vertex = info.skin.slots_per_vertex;
      row.worst_edge_stretch = 1.0;
      for (const Points& x : posed[v])
        row.worst_edge_stretch = std::max(row.worst_edge_stretch, validation::worst_edge_stretch(rest_mesh, x));
      std::sort(times[v].begin(), times[v].end());
      row.skin_us = 1e6 * times[v][times[v].size() / 2];
      std::vector<double> to_rigid;
      for (std::size_t d = 0; d < kDeformations.size(); ++d) {
        std::vector<double> e;
        for (std::size_t i = 0; i < rest.size(); ++i) {
          e.push_back((posed[v][d][i] - posed.back()[d][i]).norm());
          to_rigid.push_back((posed[v][d][i] - rigid[d][i]).norm());
        }
        const auto [mx, p99] = max_p99(e);
        row.max_error.push_back(mx);
        row.p99_error.push_back(p99);
      }
      std::tie(row.rigid_max, row.rigid_p99) = max_p99(to_rigid);
      row.volume_change =
          closed ? volume_of(*worlds[v], posed[v][1]) / rest_volume - 1.0 : std::numeric_limits<double>::quiet_NaN();
      row.rest_correction = info.skin.max_rest_correction;
      row.left_out = info.skin.max_dropped_mass;
      study.rows.push_back(row);
    }
  }
  return study;
}

std::string anatomy_markdown(const AnatomyStudy& s) {
  std::string out =
      "| organ | vertices | cage rings | `skinning` | slots a vertex | skinning µs | vs full MVC, max mm: rest / 90° "
      "bend / grasp and lift / rigid motion | 99th pct mm (same) | vs rigid cross-sections: max mm | 99th pct mm "
      "| worst edge | volume, 90° bend | rest correction max mm | weight left out max |\n"
      "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const AnatomyRow& r : s.rows) {
    std::string maxes, p99s;
    for (std::size_t d = 0; d < r.max_error.size(); ++d) {
      maxes += fmt::format("{}{:.2f}", d ? " / " : "", 1e3 * r.max_error[d]);
      p99s += fmt::format("{}{:.2f}", d ? " / " : "", 1e3 * r.p99_error[d]);
    }
    out += fmt::format(
        "| {} | {} | {} | {} | {:.2f} | {:.0f} | {} | {} | {:.1f} | {:.1f} | {:.2f}× | {} | {:.1f} | {:.3f} |\n",
        r.organ, r.vertices, r.rings, r.skin, r.slots_per_vertex, r.skin_us, maxes, p99s, 1e3 * r.rigid_max,
        1e3 * r.rigid_p99, r.worst_edge_stretch,
        std::isnan(r.volume_change) ? std::string("(open)") : fmt::format("{:+.2f} %", 100.0 * r.volume_change),
        1e3 * r.rest_correction, r.left_out);
  }
  return out;
}

}  // namespace haustra::import
