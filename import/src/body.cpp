// The body around the organs: read and closed as a container, and which way its back faces.
#include "body.hpp"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <numbers>

#include "haustra/embree_scene.hpp"
#include "haustra/error.hpp"
#include "haustra/tube_axis.hpp"
#include "import_phases.hpp"
#include "surface_repair.hpp"

namespace haustra::import {
namespace {

constexpr double kGravity = 9.81;  // m/s²

// Each boundary loop (where a scan's field of view cut the body) closed by a fan around its centre,
// wound as the triangles along it are. Returns the loops closed.
int cap_open_ends(TriangleMesh& mesh) {
  const auto loops = boundary_loops(mesh);
  for (const auto& loop : loops) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (std::uint32_t v : loop) centre += mesh.vertices[v];
    centre /= static_cast<double>(loop.size());
    const auto c = static_cast<std::uint32_t>(mesh.vertices.size());
    mesh.vertices.push_back(centre);
    // A loop runs the way its triangles do along it: the cap runs each edge the other way.
    for (std::size_t i = 0; i < loop.size(); ++i) mesh.triangles.push_back({loop[(i + 1) % loop.size()], loop[i], c});
  }
  return static_cast<int>(loops.size());
}

// The body's solid: volume, centroid and covariance (second moments about the centroid), from the
// tetrahedra its triangles make with a point inside its box.
struct Solid {
  double volume = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};
Solid solid_of(const TriangleMesh& m) {
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  for (const auto& v : m.vertices) o += v;
  o /= static_cast<double>(std::max<std::size_t>(1, m.vertices.size()));
  Solid s;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d a = m.vertices[t[0]] - o, b = m.vertices[t[1]] - o, c = m.vertices[t[2]] - o;
    const double v = a.dot(b.cross(c)) / 6.0;
    const Eigen::Vector3d sum = a + b + c;
    s.volume += v;
    first += v * sum / 4.0;
    second += v / 20.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
  }
  const Eigen::Vector3d mean = first / s.volume;
  s.centroid = o + mean;
  s.covariance = second / s.volume - mean * mean.transpose();
  return s;
}

// The area-weighted centre of the organs' surfaces.
Eigen::Vector3d organs_centre(const std::vector<const TriangleMesh*>& organs) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double area = 0.0;
  for (const TriangleMesh* m : organs)
    for (const auto& t : m->triangles) {
      const Eigen::Vector3d &a = m->vertices[t[0]], &b = m->vertices[t[1]], &c = m->vertices[t[2]];
      const double w = 0.5 * (b - a).cross(c - a).norm();
      sum += w * (a + b + c) / 3.0;
      area += w;
    }
  return area > 0.0 ? Eigen::Vector3d(sum / area) : sum;
}

// The fraction of the body's surface that faces `towards` within 18° (a flat side: the back lies
// flat on the scanner's table).
double flat_towards(const TriangleMesh& m, const Eigen::Vector3d& towards) {
  double flat = 0.0, all = 0.0;
  for (const auto& t : m.triangles) {
    const Eigen::Vector3d n = (m.vertices[t[1]] - m.vertices[t[0]]).cross(m.vertices[t[2]] - m.vertices[t[0]]);
    const double area = 0.5 * n.norm();
    all += area;
    if (area > 0.0 && n.normalized().dot(towards) > 0.95) flat += area;
  }
  return all > 0.0 ? flat / all : 0.0;
}

std::string axis_name(const Eigen::Vector3d& d) {
  for (int k = 0; k < 3; ++k)
    if (std::abs(std::abs(d[k]) - 1.0) < 1e-12) return fmt::format("{}{}", d[k] > 0.0 ? '+' : '-', "xyz"[k]);
  return fmt::format("({:.3f}, {:.3f}, {:.3f})", d.x(), d.y(), d.z());
}

// Towards the body's back: along its thinnest axis (a trunk is wider than deep, longer than deep),
// taken as the frame's axis when within 25° of one (a scanner's frame: its table lies along its
// axes), away from where the organs lie (the gut lies in front of the spine and the back's
// muscles); the back's flat side (on the table) must agree. Throws when the body does not tell.
Eigen::Vector3d body_back(const Body& body, const std::vector<const TriangleMesh*>& organs, std::string& reason) {
  const Solid s = solid_of(body.mesh);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(s.covariance);
  const Eigen::Vector3d spread = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();  // ascending
  if (!(spread[0] < 0.9 * spread[1]))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--gravity supine: the body is about as deep as it is wide ({:.0f} and {:.0f} mm, rms): "
                            "its front-to-back axis cannot be told; give gravity's direction (e.g. --gravity +y)",
                            1e3 * spread[0], 1e3 * spread[1]));
  Eigen::Vector3d axis = eig.eigenvectors().col(0).normalized();
  int k = 0;
  axis.cwiseAbs().maxCoeff(&k);
  const double tilt = std::acos(std::min(1.0, std::abs(axis[k]))) * 180.0 / std::numbers::pi;
  if (tilt <= 25.0) axis = Eigen::Vector3d::Unit(k) * (axis[k] > 0.0 ? 1.0 : -1.0);
  // Away from the organs: the back.
  double min = std::numeric_limits<double>::infinity(), max = -min;
  for (const auto& v : body.mesh.vertices) {
    min = std::min(min, v.dot(axis));
    max = std::max(max, v.dot(axis));
  }
  const double forward = (organs_centre(organs) - s.centroid).dot(axis);
  if (std::abs(forward) < 0.05 * (max - min))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--gravity supine: the organs lie {:.0f} mm from the body's centre along its front-to-back "
                            "axis {} (of {:.0f} mm): its back cannot be told from its front; give gravity's direction",
                            1e3 * std::abs(forward), axis_name(axis), 1e3 * (max - min)));
  const Eigen::Vector3d back = forward > 0.0 ? Eigen::Vector3d(-axis) : axis;
  const double flat_back = flat_towards(body.mesh, back), flat_front = flat_towards(body.mesh, -back);
  if (flat_back < flat_front)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--gravity supine: the organs lie towards {} of the body's centre, so its back faces {}, "
                            "but its flattest side faces the other way ({:.0f} % of its surface against {:.0f} %: "
                            "scanned prone?); give gravity's direction",
                            axis_name(-back), axis_name(back), 100.0 * flat_front, 100.0 * flat_back));
  reason = fmt::format(
      "the body's back faces {}: its thinnest axis ({:.0f} mm rms against {:.0f} and {:.0f}{}), the organs {:.0f} mm "
      "in front of its centre, its flat side (the table's) {:.0f} % of its surface against {:.0f} % in front",
      axis_name(back), 1e3 * spread[0], 1e3 * spread[1], 1e3 * spread[2],
      tilt <= 25.0 ? fmt::format("; {:.0f}° from the frame's axis, taken as it", tilt) : std::string(),
      1e3 * std::abs(forward), 100.0 * flat_back, 100.0 * flat_front);
  return back;
}

}  // namespace

GravityChoice parse_gravity(const std::string& value) {
  std::string v;
  for (char c : value)
    if (c != ' ' && c != '[' && c != ']') v += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  GravityChoice g;
  if (v == "supine" || v == "prone") {
    g.kind = v == "supine" ? GravityChoice::Kind::supine : GravityChoice::Kind::prone;
    return g;
  }
  const bool sign = !v.empty() && (v[0] == '+' || v[0] == '-');
  if (v.size() == (sign ? 2U : 1U) && std::string("xyz").find(v.back()) != std::string::npos) {
    g.direction = {0.0, 0.0, 0.0};
    g.direction[std::string("xyz").find(v.back())] = sign && v[0] == '-' ? -1.0 : 1.0;
    return g;
  }
  // A vector: three numbers separated by commas.
  std::vector<double> d;
  bool numbers = true;
  for (std::size_t at = 0; at <= v.size() && numbers;) {
    const std::size_t comma = std::min(v.find(',', at), v.size());
    const std::string part = v.substr(at, comma - at);
    std::size_t used = 0;
    try {
      d.push_back(std::stod(part, &used));
    } catch (const std::exception&) {
      numbers = false;
    }
    numbers = numbers && used == part.size() && std::isfinite(d.back());
    at = comma + 1;
  }
  const double norm = numbers && d.size() == 3 ? std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) : 0.0;
  if (!(norm > 0.0))
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--gravity: expected -x, +x, -y, +y, -z, +z, supine, prone or a direction x,y,z (not "
                            "all zero), got '{}'",
                            value));
  for (int i = 0; i < 3; ++i) g.direction[i] = d[i] / norm;
  return g;
}

Body read_body(const std::filesystem::path& file, const std::string& units) {
  const std::string where = fmt::format("--body {}", file.string());
  TriangleMesh raw = load_mesh_as_read(file);
  if (raw.triangles.empty())
    throw Error(ErrorCode::invalid_geometry, fmt::format("{}: the body's mesh holds no triangles", where));
  for (const auto& v : raw.vertices)
    if (!v.allFinite())
      throw Error(ErrorCode::parse, fmt::format("{}: a vertex is not a finite point: every vertex must be three "
                                                "finite numbers",
                                                where));
  Body body;
  double scale = 1.0;
  std::tie(scale, body.units_reason) = decide_units(raw, units, where);
  for (auto& v : raw.vertices) v *= scale;
  RepairedSurface repaired = repair_surface(raw, where);
  body.repairs = repaired.report.text();
  body.left_out = repaired.pieces.size() - 1;
  body.mesh = std::move(repaired.pieces.front());  // the largest
  body.capped = cap_open_ends(body.mesh);
  if (!is_closed(body.mesh))
    throw Error(ErrorCode::invalid_geometry,
                fmt::format("{}: the body's boundary is not closed after its {} open ends were capped (an edge of "
                            "three triangles or more): a container must bound a volume",
                            where, body.capped));
  body.volume = mesh_volume(body.mesh.vertices, body.mesh.triangles);
  if (body.volume < 0.0) {
    for (auto& t : body.mesh.triangles) std::swap(t[1], t[2]);
    body.volume = -body.volume;
  }
  return body;
}

double outside_body(const TriangleMesh& body, const std::vector<const TriangleMesh*>& organs) {
  EmbreeScene scene;
  scene.add_triangles(body.vertices, body.triangles);
  scene.commit();
  std::size_t total = 0;
  for (const TriangleMesh* m : organs) total += m->vertices.size();
  const std::size_t stride = std::max<std::size_t>(1, total / 4000);
  std::size_t seen = 0, out = 0, index = 0;
  for (const TriangleMesh* m : organs)
    for (const auto& v : m->vertices)
      if (index++ % stride == 0) {
        ++seen;
        out += scene.inside(v) ? 0 : 1;
      }
  return seen > 0 ? static_cast<double>(out) / static_cast<double>(seen) : 0.0;
}

Eigen::Vector3d resolve_gravity(const GravityChoice& choice, const Body* body,
                                const std::vector<const TriangleMesh*>& organs, std::string& reason) {
  if (choice.kind == GravityChoice::Kind::direction) {
    const Eigen::Vector3d d(choice.direction[0], choice.direction[1], choice.direction[2]);
    reason = fmt::format("towards {} (as given)", axis_name(d));
    return kGravity * d;
  }
  const char* name = choice.kind == GravityChoice::Kind::supine ? "supine" : "prone";
  if (body == nullptr)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("--gravity {}: needs --body (the body tells its back from its front); or give gravity's "
                            "direction (e.g. --gravity +y)",
                            name));
  std::string why;
  const Eigen::Vector3d back = body_back(*body, organs, why);
  const Eigen::Vector3d down = choice.kind == GravityChoice::Kind::supine ? back : Eigen::Vector3d(-back);
  reason = fmt::format("{}, towards the body's {} ({}): {}", name,
                       choice.kind == GravityChoice::Kind::supine ? "back" : "front", axis_name(down), why);
  return kGravity * down;
}

}  // namespace haustra::import
