// The repaired surface, the centreline and the scene an import writes.
#include "scene_files.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>

#include "haustra/error.hpp"
#include "haustra/world_desc.hpp"

namespace haustra::import {
namespace {

std::string commented(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '\n' ? std::string("\n#   ") : std::string(1, c);
  while (!out.empty() && (out.back() == ' ' || out.back() == '#')) out.pop_back();
  return out;
}

std::string toml_path(const std::filesystem::path& target, const std::filesystem::path& scene_dir) {
  std::error_code ec;
  const auto rel =
      std::filesystem::relative(std::filesystem::absolute(target), std::filesystem::absolute(scene_dir), ec);
  return ec || rel.empty() ? std::filesystem::absolute(target).string() : rel.string();
}

std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// A float as TOML reads one back bit for bit (the shortest that does, with a point).
std::string toml_number(double x) {
  std::string s = fmt::format("{}", x == 0.0 ? 0.0 : x);  // no "-0"
  if (s.find_first_of(".en") == std::string::npos) s += ".0";
  return s;
}

}  // namespace

TriangleMesh joined_apart(const std::vector<const TriangleMesh*>& pieces) {
  TriangleMesh out;
  for (const TriangleMesh* p : pieces) {
    const auto base = static_cast<std::uint32_t>(out.vertices.size());
    out.vertices.insert(out.vertices.end(), p->vertices.begin(), p->vertices.end());
    for (const auto& t : p->triangles) out.triangles.push_back({base + t[0], base + t[1], base + t[2]});
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& v : out.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double nudge = 1e-6 * (hi - lo).norm();
  // Each vertex's triangles' centroid, the way a split point moves (into its own fan).
  std::vector<Eigen::Vector3d> towards(out.vertices.size(), Eigen::Vector3d::Zero());
  for (const auto& t : out.triangles) {
    const Eigen::Vector3d c = (out.vertices[t[0]] + out.vertices[t[1]] + out.vertices[t[2]]) / 3.0;
    for (std::uint32_t v : t) towards[v] += c;
  }
  std::map<std::array<float, 3>, std::uint32_t> seen;
  for (std::uint32_t v = 0; v < out.vertices.size(); ++v) {
    for (int guard = 0; guard < 8; ++guard) {
      const Eigen::Vector3d& x = out.vertices[v];
      const std::array<float, 3> key{static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())};
      if (seen.emplace(key, v).second) break;
      const Eigen::Vector3d d = towards[v] - x;
      out.vertices[v] += nudge * (d.norm() > 0.0 ? d.normalized() : Eigen::Vector3d::UnitX());
    }
  }
  return out;
}

void write_obj(const std::filesystem::path& file, const TriangleMesh& mesh, const std::string& comment) {
  std::FILE* f = std::fopen(file.string().c_str(), "w");
  if (f == nullptr) throw Error(ErrorCode::io, fmt::format("{}: cannot write the surface", file.string()));
  fmt::print(f, "# {}; metres\n", comment);
  for (const auto& v : mesh.vertices) fmt::print(f, "v {:.9g} {:.9g} {:.9g}\n", v.x(), v.y(), v.z());
  for (const auto& t : mesh.triangles) fmt::print(f, "f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
  const bool ok = std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !ok)
    throw Error(ErrorCode::io, fmt::format("{}: cannot write the surface", file.string()));
}

void write_centreline(const std::filesystem::path& file, const Polyline& p, const std::string& source) {
  nlohmann::json j;
  j["units"] = "m";
  j["source"] = source;
  for (const auto& q : p) j["points"].push_back({q.x(), q.y(), q.z()});
  std::ofstream out(file);
  out << j.dump() << "\n";
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write the centreline", file.string()));
}

namespace {

// How far the organ's own weight may sink it into what lies below (decision 0095): the support's
// stiffness is its weight per length over this.
constexpr double kWeightSag = 5e-4;  // m

// The organ's connective tissue (decision 0095): along its whole length, the tether (the engine's
// defaults) and the support under it, written out so a user sees what holds the organ. weight: N
// per metre of organ.
std::string tissue_table(const ImportOptions& o, double weight) {
  if (o.tissue == "none") return "";
  AnchorsDesc a;
  a.support = std::ceil(weight / kWeightSag / 100.0) * 100.0;
  return fmt::format(
      "[[segment.anchors]]          # connective tissue: the organ held where the surface put it\n"
      "name = \"tissue\"\nfrom = 0.0\nto = 1.0\ntarget = \"rest\"\n"
      "stiffness = {}           # N/m per metre of organ: the tether, from any side\n"
      "damping = {}              # N·s/m per metre\nslack = {}\n"
      "strength = {}            # N per metre of organ: past it an anchor tears\n"
      "support = {}             # N/m per metre, against sinking only: its weight sinks it 0.5 mm\n",
      a.stiffness, a.damping, a.slack, a.strength, a.support);
}

// One organ's [[segment]] table: the attachment that holds its far end, its connective tissue.
std::string segment_table(const SceneFileInputs& in, const std::string& name) {
  const ImportOptions& o = in.options;
  const ImportReport& r = in.report;
  const int pieces = r.chain_pieces;
  const std::filesystem::path dir = r.scene.parent_path();
  // Measured (at least 0.2 mm, at most half the radius: the half wins on a tube under 0.4 mm), or
  // 3 mm on an organ wide enough.
  const double wall = r.wall_thickness > 0.0 ? std::min(std::max(r.wall_thickness, 2e-4), 0.5 * r.median_radius)
                                             : std::min(0.003, 0.25 * r.median_radius);
  std::string profile;
  for (std::size_t i = 0; i < in.radius_profile.size(); ++i)
    profile += fmt::format("{}[{:.4f}, {:.6g}]", i == 0 ? "" : (i % 4 == 0 ? ",\n  " : ", "),
                           in.radius_profile[i].first, std::clamp(in.radius_profile[i].second, 1e-4, 0.5));
  std::string text = fmt::format(
      "[[segment]]\nname = {}\nnodes = {}{}\nradius = {:.6g}\nwall_thickness = {:.6g}{}\nbase = \"{}\n{}"
      "[segment.rest]\nshape = \"centreline\"\nfile = {}\n"
      // A solid wall: the shape the segmentation found is the one it goes back to (decision 0095).
      "[segment.law]\nbending = \"kelvin-voigt\"\ntorsion = \"kelvin-voigt\"\n"
      "[segment.beads]\ncount = {}{}\n# each bead as wide as the outer wall around its node (16 rays, smoothed)\n"
      "radius_profile = [\n  {}]\n"
      "[segment.mesh]\nfile = {}   # repaired, in metres\n"
      "[segment.mesh.cage]\nring_vertices = {}\nbinding = \"harmonic\"\n",
      toml_string(name), pieces > 1 ? (r.nodes - 1) / pieces + 1 : r.nodes,
      pieces > 1 ? fmt::format("   # per piece: {} in all", r.nodes) : "", r.median_radius, wall,
      r.wall_thickness > 0.0 ? "   # measured between the shells" : "",
      // A free base moves against a little drag of the medium; the tissue does the holding.
      o.ends == "free" ? "free\"\ndrag = 1.0   # N·s/m², the medium's" : "clamped\"",
      pieces > 1 ? fmt::format("[segment.chain]\npieces = {}   # one rod; each piece its own mesh and cage\n", pieces)
                 : "",
      toml_string(toml_path(r.centreline_file, dir)), pieces > 1 ? (r.beads + pieces - 1) / pieces : r.beads,
      pieces > 1 ? "   # per piece" : "", profile, toml_string(toml_path(r.surface_file, dir)), r.ring_vertices);
  if (o.ends == "held") text += "[[segment.attachment]]\nnode = -1                   # the far end stays where it is\n";
  // The organ's weight per length as the engine will take it: the default density, the wall written.
  text += tissue_table(o, SegmentDesc{}.material.density * 2.0 * std::numbers::pi * r.median_radius * wall * 9.81);
  return text;
}

void write_text(const std::filesystem::path& scene, const std::string& text) {
  std::ofstream out(scene);
  out << text;
  if (!out) throw Error(ErrorCode::io, fmt::format("{}: cannot write the scene", scene.string()));
}

}  // namespace

void write_scene(const SceneFileInputs& in) {
  const ImportOptions& o = in.options;
  const ImportReport& r = in.report;
  const std::string name = o.mesh.stem().string();
  const std::string text = fmt::format(
      "# Written by `haustra import {}`. What it found:\n#   {}\n\n"
      "[scene]\nname = {}\ndescription = {}\nframes = 240\n\n"
      "[world]\ndt = 0.016666666666666666\ngravity = [0.0, 0.0, -9.81]\n\n"
      "[solver]\nmode = \"newton\"\niterations = 2\n\n{}",
      o.mesh.filename().string(), commented(r.text()), toml_string(name),
      toml_string(fmt::format("{} imported: {:.3f} m of centreline, {} vertices", name, r.length, r.repaired_vertices)),
      segment_table(in, name));
  write_text(r.scene, text);
}

void write_surfaces_scene(const SurfacesSceneInputs& in) {
  const SurfacesReport& r = in.report;
  const std::filesystem::path dir = r.scene.parent_path();
  std::string names;
  for (const auto& organ : r.organs) names += fmt::format("{}{}", names.empty() ? "" : ", ", organ.name);
  std::string text = fmt::format(
      "# Written by `haustra import {}`. What it found:\n#   {}\n\n"
      "[scene]\nname = {}\ndescription = {}\nframes = 240\n\n"
      "[world]\ndt = 0.016666666666666666\ngravity = [{}, {}, {}]   # {}\n\n"
      "[solver]\nmode = \"newton\"\niterations = 2\n{}",
      in.command, commented(r.text()), toml_string(r.scene.stem().string()),
      toml_string(fmt::format("{} organ{} imported ({}){}", r.organs.size(), r.organs.size() == 1 ? "" : "s", names,
                              r.body.empty() ? "" : ", inside the body")),
      toml_number(r.gravity[0]), toml_number(r.gravity[1]), toml_number(r.gravity[2]),
      r.gravity_reason.substr(0, r.gravity_reason.find(':')),
      r.organs.size() > 1 ? "\n[contact]\nrest_exclusions = \"world\"   # organs touching in the segmentation do "
                            "not push apart at rest\n"
                          : "");
  for (std::size_t i = 0; i < r.organs.size(); ++i)
    text += fmt::format("\n{}", segment_table(SceneFileInputs{in.options[i], r.organs[i].report, in.radius_profiles[i]},
                                              r.organs[i].name));
  if (!r.body.empty())
    text += fmt::format(
        "\n[[environment.mesh]]\nname = \"body\"\nfile = {}   # repaired and closed, in metres\n"
        "container = true            # the beads stay inside it\n",
        toml_string(toml_path(r.body_file, dir)));
  write_text(r.scene, text);
}

}  // namespace haustra::import
