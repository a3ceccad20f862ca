#pragma once
// What the viewer's tests share: scratch folders, running a command, the test's own camera model
// (a pinhole, independent of the viewer's code) and the colour coverage of a screenshot.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>

#include "haustra/render/image.hpp"

namespace fs = std::filesystem;

namespace viewer_test {

inline const std::string kViewer = HAUSTRA_VIEWER;
inline const std::string kCli = HAUSTRA_CLI;
inline const std::string kSource = HAUSTRA_SOURCE_DIR;
inline const std::string kXvfb = "xvfb-run -a -s '-screen 0 1280x720x24' ";

struct Result {
  int code;
  std::string err;
};

inline fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "haustra-viewer-test" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline Result run(const std::string& command, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const int status = std::system((command + " >" + (dir / "stdout.txt").string() + " 2>" + err.string()).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(err)};
}

inline fs::path write(const fs::path& file, const std::string& text) {
  std::ofstream(file) << text;
  return file;
}

inline Eigen::Vector3d vec(const nlohmann::json& j) {
  return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
}

// The test's own camera model (not the viewer's code): a pinhole at `eye` looking at `target`,
// z up, vertical field of view, pixels with y down.
struct TestCamera {
  Eigen::Vector3d eye, forward, right, up;
  double tan_half, aspect, width, height;
  explicit TestCamera(const nlohmann::json& c) {
    eye = vec(c["eye"]);
    const Eigen::Vector3d target = vec(c["target"]);
    forward = (target - eye).normalized();
    right = forward.cross(Eigen::Vector3d::UnitZ()).normalized();
    up = right.cross(forward);
    tan_half = std::tan(0.5 * c["fov_degrees"].get<double>() * std::numbers::pi / 180.0);
    width = c["width"].get<double>();
    height = c["height"].get<double>();
    aspect = width / height;
  }
  [[nodiscard]] Eigen::Vector3d ray(double x, double y) const {
    return (forward + (2.0 * x / width - 1.0) * tan_half * aspect * right + (1.0 - 2.0 * y / height) * tan_half * up)
        .normalized();
  }
  [[nodiscard]] Eigen::Vector2d pixel(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = p - eye;
    const double depth = d.dot(forward);
    return {0.5 * width * (1.0 + d.dot(right) / (depth * tan_half * aspect)),
            0.5 * height * (1.0 - d.dot(up) / (depth * tan_half))};
  }
};

// Fractions of the 3D view (right of the panels' column) that look like tissue (red over green
// and blue) and like beads (blue over red), in linear colour.
struct Coverage {
  double tissue = 0, bead = 0;
};
inline Coverage coverage(const fs::path& png) {
  const haustra::render::Image im = haustra::render::Image::load_png(png);
  Coverage c;
  long n = 0;
  for (int y = 0; y < im.height(); ++y)
    for (int x = 390; x < im.width(); ++x, ++n) {
      const auto p = im.at(x, y);
      c.tissue += (p.r > p.g + 0.15f && p.r > p.b + 0.15f) ? 1 : 0;
      c.bead += (p.b > p.r + 0.15f) ? 1 : 0;
    }
  c.tissue /= static_cast<double>(n);
  c.bead /= static_cast<double>(n);
  return c;
}

// Runs the viewer on the demo with `script` (written to DIR/NAME.txt) and reads back its record.
inline nlohmann::json run_demo_script(const fs::path& dir, const std::string& name, const std::string& script,
                                      const std::string& scene = kSource + "/scenes/demo.toml") {
  const fs::path file = write(dir / (name + ".txt"), script);
  const Result r =
      run(kXvfb + kViewer + " " + scene + " --script " + file.string() + " --record " + (dir / "record.json").string(),
          dir);
  INFO(r.err);
  REQUIRE(r.code == 0);
  return nlohmann::json::parse(slurp(dir / "record.json"));
}

}  // namespace viewer_test
