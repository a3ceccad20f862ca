// The skin choice of docs/skinning.md: each skin against cost and error (decision 0120).
#include "haustra/studies/skinning_study.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "haustra/mesh_io.hpp"
#include "haustra/rod_curve.hpp"
#include "haustra/world.hpp"

namespace haustra::validation {
namespace {

constexpr int kNodes = 61;
constexpr double kLength = 0.3;
constexpr int kTimingRepeats = 40;

// A straight procedural rectum, 30 cm, radius 2 cm, 11 beads 3 cm apart, a 10,000-vertex mesh, in
// a world of its own with the given skinning.
}  // namespace

WorldDesc study_organ(SkinningMethod method) {
  WorldDesc w;
  w.gravity.setZero();
  w.threads = 1;
  SegmentDesc s;
  s.name = "rectum";
  s.nodes = kNodes;
  s.rest.kind = RestShapeKind::straight;
  s.rest.length = kLength;
  s.beads.enabled = true;
  s.beads.count = 11;
  s.beads.radius = 0.02;
  s.mesh.enabled = true;
  s.mesh.source = MeshSource::procedural;
  s.mesh.skinning = method;
  s.mesh.normals = false;
  w.segments.push_back(s);
  return w;
}

namespace {

using Pose = StudyPose;

// Strains with a curvature κ2 (bend) and torsion τ over [from, to] of the rod's length.
Pose shaped(const std::string& name, double from, double to, double kappa, double tau) {
  Pose p{name, std::vector<double>(4 * kNodes, 0.0)};
  for (int k = 0; k < kNodes; ++k) {
    const double s = kLength * k / (kNodes - 1);
    if (s >= from && s <= to) {
      p.strain[static_cast<std::size_t>(4 * k + 1)] = kappa;
      p.strain[static_cast<std::size_t>(4 * k + 2)] = tau;
    }
  }
  return p;
}

}  // namespace

std::vector<StudyPose> study_poses() {
  const double pi = std::numbers::pi;
  // Beads sit every 3 cm (s = 0, 3, …, 30 cm): the 90° bend lies wholly between two of them.
  return {shaped("90° bend over 6.3 cm from a bead (bend radius 4 cm, twice the organ's; 43° between beads)", 0.15,
                 0.15 + 0.5 * pi * 0.04, 25.0, 0.0),
          shaped("180° U-turn over 9 cm (bend radius 2.9 cm)", 0.105, 0.195, pi / 0.09, 0.0),
          shaped("90° twist over 6 cm", 0.12, 0.18, 0.0, 0.5 * pi / 0.06),
          shaped("helix: 90° bend and 90° twist over 9 cm", 0.105, 0.195, 0.5 * pi / 0.09, 0.5 * pi / 0.09)};
}

namespace {

double volume(const World& w, const std::vector<Eigen::Vector3d>& x) {
  const TriangleMesh m = organ_mesh(w, x);
  return mesh_volume(m.vertices, m.triangles);
}

// The reference deformation: every vertex at its rest material coordinates (arc length s and
// offset o in the rod's frame there) carried by the posed rod: x' = c'(s) + R'(s) o.
struct Transport {
  std::vector<double> s;
  std::vector<Eigen::Vector3d> o;
};

std::vector<double> section_lengths(const World& w) {
  const auto h = w.section_lengths();
  return {h.begin(), h.begin() + (kNodes - 1)};
}

Transport material_coordinates(const World& w, const std::vector<Eigen::Vector3d>& rest) {
  const std::vector<double> h = section_lengths(w);
  const auto q = w.rest_strains().data;
  const RodCurve curve(h, std::span<const double>(q.data(), 4 * kNodes), w.base_pose(0));
  Transport t;
  for (const auto& x : rest) {
    // A straight rest rod: the arc length is the projection on its axis.
    const kernels::Pose p0 = curve.pose_at(0.0);
    const double s = std::clamp((x - p0.position).dot(p0.rotation * Eigen::Vector3d::UnitZ()), 0.0, curve.length());
    const kernels::Pose p = curve.pose_at(s);
    t.s.push_back(s);
    t.o.push_back(p.rotation.conjugate() * (x - p.position));
  }
  return t;
}

std::vector<Eigen::Vector3d> transported(const World& w, const Transport& t, const std::vector<double>& strain) {
  const RodCurve curve(section_lengths(w), strain, w.base_pose(0));
  std::vector<Eigen::Vector3d> out;
  for (std::size_t i = 0; i < t.s.size(); ++i) {
    const kernels::Pose p = curve.extend(t.s[i]);
    out.push_back(p.position + p.rotation * t.o[i]);
  }
  return out;
}

}  // namespace

double skinning_seconds(const World& w) {
  const auto skin = [&w] { return w.last_profile().seconds[static_cast<std::size_t>(Stage::skin)]; };
  const double before = skin();
  (void)w.mesh_positions();  // what skins
  return skin() - before;
}

std::vector<Eigen::Vector3d> organ_points(const World& w) {
  const MeshInfo& m = w.mesh(0);
  const auto p = w.mesh_positions();
  std::vector<Eigen::Vector3d> out(m.vertices.count);
  for (std::size_t v = 0; v < out.size(); ++v) {
    const std::size_t i = m.vertices.offset + v;
    out[v] = Eigen::Vector3d(p.x[i], p.y[i], p.z[i]);
  }
  return out;
}

TriangleMesh organ_mesh(const World& w, const std::vector<Eigen::Vector3d>& x) {
  const MeshInfo& m = w.mesh(0);
  TriangleMesh out{x, {}};
  for (std::size_t i = 0; i < m.triangles.count; ++i) {
    auto tri = w.mesh_triangles()[m.triangles.offset + i];
    for (auto& v : tri) v -= static_cast<std::uint32_t>(m.vertices.offset);
    out.triangles.push_back(tri);
  }
  return out;
}

double worst_edge_stretch(const TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& x) {
  double worst = 1.0;
  for (const auto& t : mesh.triangles)
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint32_t a = t[k], b = t[(k + 1) % 3];
      const double rest = (mesh.vertices[a] - mesh.vertices[b]).norm();
      if (rest > 0.0) worst = std::max(worst, (x[a] - x[b]).norm() / rest);
    }
  return worst;
}

SkinningStudy run_skinning_study() {
  SkinningStudy study;
  study.organ = "a straight procedural rectum, 30 cm, radius 2 cm, 61 nodes, 11 beads 3 cm apart, 10,000-vertex mesh";
  const std::vector<Pose> ps = study_poses();
  for (const Pose& p : ps) study.poses.push_back(p.name);
  struct Variant {
    std::string name;
    SkinningMethod method;
  };
  // No comma in a name: the trade-off study writes it to its CSV as it is.
  const std::vector<Variant> variants = {
      // full MVC first: the reference of the "vs full MVC" columns
      {"`\"cage-full\"` (every ring: full MVC)", SkinningMethod::cage_full},
      {"`\"along-rod\"` (default: the rod's frames at each vertex's place)", SkinningMethod::along_rod},
      {"`\"cage\"` (≥ 4 rings a vertex; ≤ 2 % weight left out)", SkinningMethod::cage},
      {"`\"linear-blend\"` (2 bead frames; comparison)", SkinningMethod::linear_blend}};
  std::vector<std::vector<Eigen::Vector3d>> reference;  // full MVC per pose
  for (const Variant& v : variants) {
    std::unique_ptr<World> w = World::create(study_organ(v.method));
    const MeshInfo& info = w->mesh(0);
    study.vertices = info.vertices.count;
    study.rings = info.cage.rings;
    SkinningStudyRow row;
    row.method = v.name;
    row.skinning = v.method;
    row.slots = info.skin.mean_rings_per_vertex;
    row.slots_per_vertex = info.skin.slots_per_vertex;
    row.bytes_per_vertex = row.slots_per_vertex * 20.0;  // 4 floats and a ring index per slot
    row.rest_error = info.skin.rest_error;
    row.mean_dropped_mass = info.skin.mean_dropped_mass;
    const std::vector<Eigen::Vector3d> rest = organ_points(*w);
    Eigen::Vector3d lo = rest[0], hi = rest[0];
    for (const auto& x : rest) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    study.mesh_size = (hi - lo).norm();
    const double rest_volume = volume(*w, rest);
    const TriangleMesh rest_mesh = organ_mesh(*w, rest);
    const kernels::Pose base = w->base_pose(0);
    std::vector<double> errors, transport_errors;
    std::vector<double> times;
    const Transport transport = material_coordinates(*w, rest);
    for (std::size_t pi = 0; pi < ps.size(); ++pi) {
      for (int r = 0; r < kTimingRepeats; ++r) {
        w->pose_rod(0, base, ps[pi].strain);
        times.push_back(skinning_seconds(*w));
      }
      const std::vector<Eigen::Vector3d> x = organ_points(*w);
      if (v.method == SkinningMethod::cage_full) reference.push_back(x);
      row.worst_edge_stretch = std::max(row.worst_edge_stretch, worst_edge_stretch(rest_mesh, x));
      for (std::size_t i = 0; i < x.size(); ++i) errors.push_back((x[i] - reference[pi][i]).norm());
      const std::vector<Eigen::Vector3d> carried = transported(*w, transport, ps[pi].strain);
      study.transport_worst_edge = std::max(study.transport_worst_edge, worst_edge_stretch(rest_mesh, carried));
      for (std::size_t i = 0; i < x.size(); ++i) transport_errors.push_back((x[i] - carried[i]).norm());
      if (pi == 0) study.transport_bend_volume_change = volume(*w, carried) / rest_volume - 1.0;
      if (pi == 2) study.transport_twist_volume_change = volume(*w, carried) / rest_volume - 1.0;
      const double change = volume(*w, x) / rest_volume - 1.0;
      if (pi == 0) row.bend_volume_change = change;
      if (pi == 2) row.twist_volume_change = change;
    }
    std::sort(times.begin(), times.end());
    row.skin_us = 1e6 * times[times.size() / 2];
    std::sort(errors.begin(), errors.end());
    row.max_error = errors.back();
    row.p99_error = errors[static_cast<std::size_t>(0.99 * static_cast<double>(errors.size() - 1))];
    std::sort(transport_errors.begin(), transport_errors.end());
    row.transport_max = transport_errors.back();
    row.transport_p99 =
        transport_errors[static_cast<std::size_t>(0.99 * static_cast<double>(transport_errors.size() - 1))];
    study.rows.push_back(row);
  }
  return study;
}

std::string skinning_markdown(const SkinningStudy& s) {
  std::string out;
  out += fmt::format("Organ: {} ({} vertices, {} cage rings, mesh size {:.3f} m). Poses, set directly on the rod:\n",
                     s.organ, s.vertices, s.rings, s.mesh_size);
  for (const auto& p : s.poses) out += fmt::format("- {}\n", p);
  out +=
      "\nErrors are distances over every vertex of every pose: from rigid cross-sections (each vertex carried by "
      "the rod's own frame at its rest arc length) and from full mean value coordinates (every ring of the cage); "
      "the worst edge is the longest mesh edge over its rest length (the rod does not stretch in these poses: the "
      "outer wall of the U-turn does, as the rigid cross-sections' own worst edge shows); "
      "volumes are of the closed mesh, relative to its rest volume. Slots a vertex: what skinning reads per vertex "
      "(blocks of 8 vertices, padding included; 20 bytes each). Skinning time: the `skin` stage on one thread, "
      "median over the poses.\n\n";
  out +=
      "| `skinning` | slots a vertex | bytes a vertex | skinning µs | vs rigid cross-sections: max mm | 99th pct mm "
      "| vs full MVC: max mm | 99th pct mm | worst edge | volume, 90° bend | volume, 90° twist | rest error m |\n";
  out += "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : s.rows)
    out += fmt::format(
        "| {} | {:.2f} | {:.0f} | {:.1f} | {:.2f} | {:.2f} | {:.3f} | {:.3f} | {:.3f}× | {:+.2f} % | {:+.2f} % "
        "| {:.1e} |\n",
        r.method, r.slots_per_vertex, r.bytes_per_vertex, r.skin_us, 1e3 * r.transport_max, 1e3 * r.transport_p99,
        1e3 * r.max_error, 1e3 * r.p99_error, r.worst_edge_stretch, 100.0 * r.bend_volume_change,
        100.0 * r.twist_volume_change, r.rest_error);
  out += fmt::format("| rigid cross-sections (reference) | | | | 0 | 0 | | | {:.3f}× | {:+.2f} % | {:+.2f} % | |\n",
                     s.transport_worst_edge, 100.0 * s.transport_bend_volume_change,
                     100.0 * s.transport_twist_volume_change);
  return out;
}

}  // namespace haustra::validation
