// `haustra view` as a workbench, under Xvfb and driven by scripts in lockstep: File > Open and
// Reload, a video at the physics' own time, the help overlay, the inspector's edits against the
// elastica, the camera's views around the organ, and picking what is drawn on the small intestine.
#include <doctest/doctest.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "haustra/render/image.hpp"
#include "haustra/studies/references.hpp"
#include "viewer_harness.hpp"

using namespace viewer_test;

namespace {

std::string log_of(const nlohmann::json& rec) {
  std::string log;
  for (const auto& line : rec["log"]) log += line.get<std::string>() + "\n";
  return log;
}

// Fraction of the window's middle (where the help overlay sits) that is dark, as ImGui's windows are.
double dark_middle(const fs::path& png) {
  const haustra::render::Image im = haustra::render::Image::load_png(png);
  long dark = 0, n = 0;
  for (int y = im.height() / 4; y < 3 * im.height() / 4; ++y)
    for (int x = im.width() / 2 - 150; x < im.width() / 2 + 150; ++x, ++n) {
      const auto p = im.at(x, y);
      dark += (p.r + p.g + p.b < 0.3f) ? 1 : 0;
    }
  return static_cast<double>(dark) / static_cast<double>(n);
}

// A line of ffprobe's answer about the video's stream, "key=value".
std::string probe(const std::string& answer, const std::string& key) {
  const std::size_t at = answer.find(key + "=");
  if (at == std::string::npos) return "";
  const std::size_t from = at + key.size() + 1;
  return answer.substr(from, answer.find('\n', from) - from);
}

}  // namespace

TEST_CASE("haustra view: a video at the physics' own time, the help overlay, File > Open and Reload") {
  const fs::path dir = scratch("workbench");
  const fs::path scene = dir / "cantilever.toml";
  fs::copy_file(kSource + "/scenes/cantilever.toml", scene);
  const fs::path video = dir / "pull.mp4";
  const nlohmann::json rec =
      run_demo_script(dir, "bench",
                      "wait 2\nrecord " + video.string() +
                          "\nwait 120\nrecord stop\nwait 1\n"
                          "screenshot " +
                          (dir / "plain.png").string() + "\nkey F1\nwait 1\nscreenshot " + (dir / "help.png").string() +
                          "\nkey ESC\nopen " + scene.string() + "\nwait 10\nkey CTRL+R\nwait 3\nquit\n");
  const std::string log = log_of(rec);
  INFO(log);
  // 120 physics frames of 1/60 s recorded at 30 frames a second of simulated time: 60 frames, 2 s.
  CHECK(log.find("2 physics frames each") != std::string::npos);
  CHECK(log.find("pull.mp4: 60 frames") != std::string::npos);
  const Result p =
      run("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
          "stream=nb_read_frames,width,height,r_frame_rate -of default=noprint_wrappers=1 " +
              video.string(),
          dir);
  const std::string stream = slurp(dir / "stdout.txt");
  INFO(p.err);
  INFO(stream);
  REQUIRE(p.code == 0);
  CHECK(probe(stream, "nb_read_frames") == "60");
  CHECK(probe(stream, "r_frame_rate") == "30/1");
  CHECK(probe(stream, "width") == "1280");
  CHECK(probe(stream, "height") == "720");
  // F1 lays the help over the middle of the window; Esc takes it away again (the quit came later).
  const double plain = dark_middle(dir / "plain.png"), help = dark_middle(dir / "help.png");
  MESSAGE("dark middle: " << plain << " without the help, " << help << " with it");
  CHECK(plain < 0.1);  // measured 0.00: sky and floor
  CHECK(help > 0.5);   // measured 0.9
  // Opened from the window's path, then reloaded: the scene is the cantilever, started again.
  CHECK(rec["scene"] == "cantilever");
  std::size_t opened = 0;
  for (std::size_t at = log.find("opened " + scene.string()); at != std::string::npos;
       at = log.find("opened " + scene.string(), at + 1))
    ++opened;
  CHECK(opened == 2);
  CHECK(rec["frames"].get<int>() <= 4);  // the reload started at frame 0 three frames before the end
}

TEST_CASE("haustra view: the inspector's edit of E makes the cantilever stiffer, each shape the elastica's") {
  // scenes/cantilever.toml: PL²/B = 3 at E = 1 MPa; E × 4 makes it 0.75.
  const fs::path dir = scratch("inspector");
  const nlohmann::json rec = run_demo_script(dir, "stiffer",
                                             "wait 10\nselect organ 0\nedit organ 0 youngs_modulus 4e6\nwait 10\n"
                                             "edit organ 0 stiffness 3\nedit organ 0 youngs_modulus -1\n"
                                             "edit instrument 0 force_limit 5\nselect organ 5\nwait 1\nquit\n",
                                             kSource + "/scenes/cantilever.toml");
  const std::string log = log_of(rec);
  INFO(log);
  const auto& samples = rec["samples"];
  REQUIRE(samples.size() >= 20);
  const Eigen::Vector3d before = vec(samples[9]["end"]), after = vec(samples.back()["end"]);
  const auto soft = haustra::reference::elastica_cantilever_tip(3.0);
  const auto stiff = haustra::reference::elastica_cantilever_tip(0.75);
  const double error_before = std::hypot(before.x() - soft.x, before.z() - soft.z);
  const double error_after = std::hypot(after.x() - stiff.x, after.z() - stiff.z);
  MESSAGE("tip sag " << -before.z() << " m, then " << -after.z() << " m; from the elastica " << error_before << " and "
                     << error_after << " m");
  CHECK(-after.z() < 0.5 * -before.z());  // 0.236 m against 0.603 m
  CHECK(error_before < 3e-4);             // measured 2.5e-5 m (the discretization's, N = 100)
  CHECK(error_after < 3e-4);
  CHECK(log.find("rod: E 1e+06 -> 4e+06 Pa") != std::string::npos);  // announced with what it rebuilt
  CHECK(log.find("rods rebuilt, meshes kept") != std::string::npos);
  CHECK(log.find("edit organ: no field 'stiffness' (youngs_modulus, relaxation_time)") != std::string::npos);
  CHECK(log.find("edit organ youngs_modulus: -1 is not more than zero (Pa)") != std::string::npos);
  CHECK(log.find("mouse: coupling") != std::string::npos);  // the mouse's instrument edited too
  CHECK(log.find("limit 8 -> 5 N") != std::string::npos);
  CHECK(log.find("select: no organ 5 (the scene has 1)") != std::string::npos);
}

TEST_CASE(
    "haustra view: the front, top, side and default views each hold the whole organ, and orbiting stays above the "
    "floor") {
  const fs::path dir = scratch("cameras");
  const nlohmann::json rec =
      run_demo_script(dir, "views",
                      "wait 2\npause\nkey 1\nwait 1\nwait 1\nkey 2\nwait 1\nwait 1\nkey 3\nwait 1\nwait 1\n"
                      "key 0\nwait 1\nwait 1\npress 1200 120\nmove by 0 -600 10\nrelease\n"
                      "wait 1\nwait 1\nquit\n");
  int views = 0, checked_orbit = 0;
  const auto& events = rec["events"];
  // Each view as drawn: the camera a frame after the key (or the orbit), when the fit has been made.
  for (std::size_t i = 2; i < events.size(); ++i) {
    const std::string after = events[i - 2]["kind"].get<std::string>();
    if (events[i]["kind"] != "script wait" || events[i - 1]["kind"] != "script wait" ||
        (after != "script key" && after != "release"))
      continue;
    const TestCamera cam(events[i]["camera"]);
    const Eigen::Vector3d lo = vec(events[i]["drawn"][0]), hi = vec(events[i]["drawn"][1]);
    REQUIRE((hi - lo).norm() > 0.05);
    CAPTURE(i);
    CAPTURE(after);
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d p((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(),
                              (corner & 4) ? hi.z() : lo.z());
      CHECK((p - cam.eye).dot(cam.forward) > 0.0);
      const Eigen::Vector2d px = cam.pixel(p);
      CAPTURE(px.transpose());
      CHECK(px.x() > 370.0);  // right of the panels' column
      CHECK(px.x() < cam.width);
      CHECK(px.y() > 20.0);  // under the menu bar
      CHECK(px.y() < cam.height);
    }
    CHECK(cam.eye.z() > 0.0);  // the demo's floor is z = 0
    ++views;
    checked_orbit += after == "release" ? 1 : 0;
  }
  CHECK(views == 5);  // four keys, and after the orbit
  CHECK(checked_orbit == 1);
}

TEST_CASE("haustra view: a press on any part of the small intestine's drawn loops grasps it") {
  // Two runs of one script: the first shows where the loops are drawn, the second presses there.
  const fs::path dir = scratch("picking");
  const std::string scene = kSource + "/scenes/small-intestine.toml";
  run_demo_script(dir, "look", "wait 3\nscreenshot " + (dir / "loops.png").string() + "\nquit\n", scene);
  const haustra::render::Image im = haustra::render::Image::load_png(dir / "loops.png");
  // Tissue pixels (reddish), right of the panels: one press near each corner of their box and in its
  // middle, each on a pixel the organ covers.
  std::vector<Eigen::Vector2i> tissue;
  for (int y = 30; y < im.height(); ++y)
    for (int x = 390; x < im.width(); ++x) {
      const auto p = im.at(x, y);
      if (p.r > p.g + 0.15f && p.r > p.b + 0.15f) tissue.emplace_back(x, y);
    }
  REQUIRE(tissue.size() > 10000);
  Eigen::Vector2i lo = tissue[0], hi = tissue[0];
  for (const auto& t : tissue) lo = lo.cwiseMin(t), hi = hi.cwiseMax(t);
  std::string script = "wait 3\n";
  const std::vector<Eigen::Vector2d> aims = {{0.25, 0.25}, {0.75, 0.25}, {0.5, 0.5}, {0.25, 0.75}, {0.75, 0.75}};
  for (const auto& a : aims) {
    const Eigen::Vector2d aim = lo.cast<double>() + a.cwiseProduct((hi - lo).cast<double>());
    const auto nearest = *std::min_element(tissue.begin(), tissue.end(), [&](const auto& p, const auto& q) {
      return (p.template cast<double>() - aim).squaredNorm() < (q.template cast<double>() - aim).squaredNorm();
    });
    script += fmt::format("press {} {}\nwait 2\nrelease\nwait 1\n", nearest.x(), nearest.y());
  }
  const nlohmann::json rec = run_demo_script(dir, "press", script + "quit\n", scene);
  int presses = 0, on_organ = 0;
  for (const auto& e : rec["events"])
    if (e["kind"] == "press") ++presses, on_organ += e["on_organ"] == true ? 1 : 0;
  int grasps = 0;
  bool was = false;
  for (const auto& s : rec["samples"]) {
    grasps += s["grasping"] == true && !was ? 1 : 0;
    was = s["grasping"] == true;
  }
  CHECK(presses == 5);
  CHECK(on_organ == 5);
  CHECK(grasps == 5);
}
