// Rest shapes: constant-strain rods, the biarc construction from a polyline, centreline files.
#include <doctest/doctest.h>

#include <numbers>

#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/kernels/rod_forward_sweep.hpp"
#include "haustra/rest_shape.hpp"
#include "haustra/rod_pose_buffer.hpp"

using namespace haustra;

namespace {

std::vector<Eigen::Vector3d> reconstruct(const RestShape& r) {
  const std::size_t n = r.section_length.size() + 1;
  RodPoseBuffer buffer(n);
  const kernels::RodPoses<double> p = buffer.view();
  kernels::rod_forward_sweep(r.base, r.section_length, kernels::StrainView<const double>{r.strain}, p);
  std::vector<Eigen::Vector3d> out;
  for (std::size_t k = 0; k < n; ++k) out.push_back(p.node_position.get(k));
  return out;
}

// A helix of radius a and pitch 2πc along z, by arc length.
Eigen::Vector3d helix(double s, double a, double c) {
  const double w = 1.0 / std::sqrt(a * a + c * c);
  return {a * std::cos(w * s), a * std::sin(w * s), c * w * s};
}

}  // namespace

TEST_CASE("constant strain rest shape is an exact helix") {
  // A helix has curvature a/(a²+c²) and torsion c/(a²+c²) in a frame with d1 along the normal.
  const double a = 0.3, c = 0.1, len = 2.0;
  const double k = a / (a * a + c * c), t = c / (a * a + c * c);
  // Start frame: tangent, normal −d1 points to the axis... choose d2 as the principal normal.
  const double w = 1.0 / std::sqrt(a * a + c * c);
  const Eigen::Vector3d tangent(0.0, a * w, c * w), normal(-1.0, 0.0, 0.0);
  Eigen::Matrix3d r;
  r.col(2) = tangent;
  r.col(1) = normal;
  r.col(0) = normal.cross(tangent);
  const kernels::Pose base{Eigen::Quaterniond(r), helix(0.0, a, c)};
  // Rotation about d1 turns d3 towards −d2: curvature about d1 is −κ for d2 = normal.
  const RestShape rest = rest_shape_constant_strain(33, len, Eigen::Vector3d(-k, 0.0, t), base);
  const auto nodes = reconstruct(rest);
  for (std::size_t i = 0; i < nodes.size(); ++i)
    CHECK((nodes[i] - helix(len * static_cast<double>(i) / 32.0, a, c)).norm() < 1e-13);
}

TEST_CASE("node strains reproduce the section strains exactly and stay smooth") {
  std::vector<double> h = {0.1, 0.12, 0.09, 0.1, 0.11};
  std::vector<double> sec;
  for (std::size_t k = 0; k < h.size(); ++k) {
    const double v = 1.0 + 0.2 * static_cast<double>(k);
    sec.insert(sec.end(), {v, -v, 0.5, 0.0});
  }
  const std::vector<double> q = node_strains_from_sections(sec, h);
  for (std::size_t k = 0; k < h.size(); ++k)
    for (std::size_t c = 0; c < 4; ++c)
      CHECK(0.5 * (q[4 * k + c] + q[4 * k + 4 + c]) == doctest::Approx(sec[4 * k + c]).epsilon(1e-14));
  // Constant section strains give constant node strains (no alternating component).
  std::vector<double> flat(4 * h.size(), 2.0);
  for (double v : node_strains_from_sections(flat, h)) CHECK(v == doctest::Approx(2.0).epsilon(1e-14));
}

TEST_CASE("biarc rest shape passes through its samples and converges to a smooth curve") {
  // A finely sampled helix, resampled to N+1 nodes.
  std::vector<Eigen::Vector3d> poly;
  const double a = 0.05, c = 0.02, len = 0.6;
  for (int i = 0; i <= 2000; ++i) poly.push_back(helix(len * i / 2000.0, a, c));
  double previous = 1e9;
  for (int nodes : {21, 41, 81, 161}) {
    const RestShape rest = rest_shape_from_centreline(poly, nodes, Eigen::Vector3d::UnitZ(), "helix");
    INFO("nodes " << nodes << " node deviation " << rest.node_deviation << " polyline deviation "
                  << rest.polyline_deviation);
    CHECK(rest.node_deviation < 1e-12);
    CHECK(rest.polyline_deviation < previous);  // more nodes, closer to the source
    CHECK(rest.length == doctest::Approx(len).epsilon(0.01));
    previous = rest.polyline_deviation;
    // Rotation-minimizing by construction: no torsion within any section.
    for (std::size_t k = 0; k + 1 < rest.section_length.size() + 1; ++k)
      CHECK(std::abs(0.5 * (rest.strain[4 * k + 2] + rest.strain[4 * k + 6])) < 1e-9);
  }
  CHECK(previous < 1e-4);  // 0.1 mm on a 6 cm-wide helix at 161 nodes
}

TEST_CASE("an odd section count ends with a single arc and still interpolates") {
  std::vector<Eigen::Vector3d> poly;
  for (int i = 0; i <= 500; ++i) {
    const double t = i / 500.0;
    poly.emplace_back(t, 0.2 * std::sin(3.0 * t), 0.1 * t * t);
  }
  const RestShape rest = rest_shape_from_centreline(poly, 40, Eigen::Vector3d::UnitZ(), "curve");  // 39 sections
  CHECK(rest.section_length.size() == 39);
  CHECK(rest.node_deviation < 1e-12);
  CHECK(rest.polyline_deviation < 2e-3);
}

TEST_CASE("centreline files: units are converted, bad input is named") {
  const Centreline c = parse_centreline(R"({"units": "mm", "points": [[0,0,0],[10,0,0],[20,5,0]]})", "c.json");
  CHECK(c.points.size() == 3);
  CHECK(c.points[1].x() == doctest::Approx(0.01));
  auto error_of = [](const std::string& text) {
    try {
      parse_centreline(text, "bad.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(error_of("{").find("not valid JSON") != std::string::npos);
  CHECK(error_of(R"({"points": [[0,0,0],[1,0,0]]})").find("'units'") != std::string::npos);
  CHECK(error_of(R"({"units": "inch", "points": [[0,0,0],[1,0,0]]})").find("\"inch\"") != std::string::npos);
  CHECK(error_of(R"({"units": "m", "points": [[0,0,0]]})").find("at least 2 points") != std::string::npos);
  CHECK(error_of(R"({"units": "m", "points": [[0,0,0],[1,0]]})").find("points[1]") != std::string::npos);
  CHECK(error_of(R"({"units": "m", "points": [[0,0,0],["a",0,0]]})").find("points[1]") != std::string::npos);
  CHECK(error_of(R"({"units": "m", "points": [[0,0,0],[1,0,0],[1,0,0]]})").find("points 1 and 2 are the same") !=
        std::string::npos);
  CHECK(error_of(R"({"units": "m", "points": [[0,0,0],[1,0,0],[0.5,0.001,0]]})").find("reverses at point 1") !=
        std::string::npos);
  CHECK(error_of(R"({"units": "m", "points": [[0,0,0],[1e400,0,0]]})").find("bad.json") != std::string::npos);
  try {
    read_centreline("/nonexistent/file.json");
    FAIL("no error");
  } catch (const Error& e) {
    CHECK(e.code() == ErrorCode::io);
    CHECK(std::string(e.what()).find("/nonexistent/file.json") != std::string::npos);
  }
}
