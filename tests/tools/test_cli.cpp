// The haustra command line, end to end: the binary as a user runs it.
#include <doctest/doctest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include "haustra/scene.hpp"
#include "haustra/studies/references.hpp"
#include "haustra/world.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kCli = HAUSTRA_CLI;
const std::string kCliScenes = std::string(HAUSTRA_SOURCE_DIR) + "/scenes/";

struct Result {
  int code;
  std::string out, err;
};

Result run(const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / "haustra-cli-test";
  fs::create_directories(dir);
  const auto id = std::to_string(std::hash<std::string>{}(args));
  const fs::path out = dir / (id + ".out"), err = dir / (id + ".err");
  const int status = std::system((kCli + " " + args + " >" + out.string() + " 2>" + err.string()).c_str());
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  };
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

nlohmann::json summary(const fs::path& dir) {
  std::ifstream in(dir / "summary.json");
  REQUIRE(in.good());
  return nlohmann::json::parse(in);
}

fs::path out_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / "haustra-cli-test" / name;
  fs::remove_all(d);
  return d;
}

}  // namespace

TEST_CASE("haustra run writes a summary with counts, stage times and final positions") {
  const fs::path dir = out_dir("cantilever");
  const Result r = run("run " + kCliScenes + "cantilever.toml --quiet --out " + dir.string());
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(r.out.find("outputs in") != std::string::npos);
  const auto j = summary(dir);
  CHECK(j["scene"] == "cantilever");
  CHECK(j["status"] == "ok");
  CHECK(j["counts"]["segments"] == 1);
  CHECK(j["counts"]["nodes"] == 101);
  CHECK(j["counts"]["sections"] == 100);
  CHECK(j["frames"] == 30);
  // A Newton scene: the condensed solve, and the line search that leaves the poses of its step.
  CHECK(j["stages"]["condense"]["ran"] == true);
  CHECK(j["stages"]["line_search"]["ran"] == true);
  CHECK(j["stages"]["line_search"]["median_us"].get<double>() > 0.0);
  CHECK(j["stages"]["forward_sweep"]["ran"] == false);
  CHECK(j["stages"]["filter"]["ran"] == false);  // the scene switches the filter off
  // The tip against the elastica: the scene is the PL²/B = 3 cantilever of length 1 m.
  const auto tip = j["segments"][0]["final_node_positions_m"].back();
  const auto ref = haustra::reference::elastica_cantilever_tip(3.0);
  const double err = std::hypot(tip[0].get<double>() - ref.x, tip[2].get<double>() - ref.z);
  CHECK(err < 3e-4 * std::hypot(1.0 - ref.x, ref.z));  // measured 3.8e-5 of the tip's deflection
  CHECK(fs::exists(dir / "frames.csv"));
  CHECK(fs::exists(dir / "nodes.csv"));
}

TEST_CASE("haustra run drop: summary.json has the floor and self penetration of every frame") {
  const fs::path dir = out_dir("drop");
  const Result r = run("run " + kCliScenes + "drop.toml --frames 90 --out " + dir.string());
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  CHECK(r.out.find("contacts (55 beads): deepest into the environment") != std::string::npos);
  const auto j = summary(dir);
  const auto& c = j["contacts"];
  CHECK(c["beads"] == 55);
  const auto& floor = c["per_frame"]["max_environment_depth_over_radius"];
  const auto& self = c["per_frame"]["max_bead_overlap_over_radius"];
  REQUIRE(floor.size() == 90);
  REQUIRE(self.size() == 90);
  REQUIRE(c["per_frame"]["max_environment_depth_m"].size() == 90);
  REQUIRE(c["per_frame"]["touching"].size() == 90);
  double worst_floor = 0.0, worst_self = 0.0;
  for (std::size_t f = 0; f < 90; ++f) {
    worst_floor = std::max(worst_floor, floor[f].get<double>());
    worst_self = std::max(worst_self, self[f].get<double>());
    // Depth over radius is the depth in m over the 2 cm radius of every bead of this scene.
    CHECK(floor[f].get<double>() == doctest::Approx(c["per_frame"]["max_environment_depth_m"][f].get<double>() / 0.02));
  }
  CHECK(c["max_environment_depth_over_radius"].get<double>() == worst_floor);
  CHECK(c["max_bead_overlap_over_radius"].get<double>() == worst_self);
  CHECK(floor[0].get<double>() == 0.0);  // hanging: nothing touches at first
  CHECK(worst_floor > 0.0);              // it lands within 1.5 s
  CHECK(worst_floor < 0.2);
}

TEST_CASE("haustra run grasp-pull: the instrument force of every frame, grasping from 0.6 s") {
  const fs::path dir = out_dir("grasp-pull");
  const Result r = run("run " + kCliScenes + "grasp-pull.toml --frames 60 --quiet --out " + dir.string());
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  const auto j = summary(dir);
  const auto& g = j["instruments"][0];
  REQUIRE(g["force_N_per_frame"].size() == 60);
  REQUIRE(g["grasping_per_frame"].size() == 60);
  CHECK(g["grasping_per_frame"][34] == false);
  CHECK(g["grasping_per_frame"][35] == true);                // the 36th frame ends at 0.6 s
  CHECK(g["force_N_per_frame"][59][2].get<double>() < 0.0);  // holding tissue: pulled down
}

TEST_CASE("haustra run: --threads 1 and --threads 2 give bit-identical final positions") {
  for (const std::string scene : {"ropes", "rope"}) {
    const fs::path one = out_dir(scene + "-1"), two = out_dir(scene + "-2");
    REQUIRE(run("run " + kCliScenes + scene + ".toml --quiet --frames 60 --threads 1 --out " + one.string()).code == 0);
    REQUIRE(run("run " + kCliScenes + scene + ".toml --quiet --frames 60 --threads 2 --out " + two.string()).code == 0);
    const auto a = summary(one), b = summary(two);
    CHECK(a["threads"] == 1);
    CHECK(b["threads"] == 2);
    INFO(scene);
    CHECK(a["segments"] == b["segments"]);  // every coordinate, printed to round-trip precision
  }
}

TEST_CASE("haustra run: --set and --dt override the scene") {
  const fs::path dir = out_dir("set");
  const Result r = run("run " + kCliScenes +
                       "ropes.toml --quiet --frames 2 --dt 0.001 --set segment.nodes=11 --set "
                       "segment[0].nodes=21 --out " +
                       dir.string());
  INFO(r.err);
  REQUIRE(r.code == 0);
  const auto j = summary(dir);
  CHECK(j["counts"]["nodes"] == 21 + 5 * 11);
  CHECK(j["dt"] == 0.001);
}

TEST_CASE("haustra run: the command line's own bad values, and a device as the scene, are named as such") {
  const Result threads = run("run " + kCliScenes + "ropes.toml --quiet --threads -3");
  CHECK(threads.code == 2);
  CHECK(threads.err.find("--threads -3: expected 0 (all hardware threads) to 1024") != std::string::npos);
  CHECK(threads.err.find("ropes.toml") == std::string::npos);  // not blamed on the scene file
  const Result dt = run("run " + kCliScenes + "ropes.toml --quiet --dt 5e-324");
  CHECK(dt.code == 2);
  CHECK(dt.err.find("--dt 5e-324: expected a time step in [1e-06, 1] s") != std::string::npos);
  const Result zero = run("run /dev/zero --quiet");  // it grew past 1.25 GB in 13 s
  CHECK(zero.code == 2);
  CHECK(zero.err.find("/dev/zero: a character device, not a scene file") != std::string::npos);
}

TEST_CASE("haustra estimate: the world's memory and time before it is built, as World::create and the APIs see them") {
  const Result text = run("estimate " + kCliScenes + "drop.toml");
  CHECK(text.code == 0);
  CHECK(text.out.find("haustra estimate: drop") != std::string::npos);
  CHECK(text.out.find("167 nodes") != std::string::npos);
  CHECK(text.out.find("55 beads") != std::string::npos);
  CHECK(text.out.find("a frame at rest") != std::string::npos);
  const Result json = run("estimate " + kCliScenes + "drop.toml --json --set segment.nodes=20000");
  REQUIRE(json.code == 0);
  const nlohmann::json j = nlohmann::json::parse(json.out);
  const haustra::MemoryEstimate e = haustra::estimate_memory(
      haustra::load_scene(kCliScenes + "drop.toml", std::vector<std::string>{"segment.nodes=20000"}).world);
  CHECK(j["total"].get<std::size_t>() == e.total);
  CHECK(j["nodes"].get<std::size_t>() == 20000);
  CHECK(j["bead_pairs"].get<std::size_t>() == e.bead_pairs);
  CHECK(j["step_seconds"].get<double>() == e.step_seconds);
  CHECK(j["fits"].get<bool>());
  // A world past its budget: exit 2 with World::create's own reason.
  const Result big = run("estimate " + kCliScenes + "drop.toml --set segment.nodes=10000000 world.memory_limit=1e9");
  CHECK(big.code == 2);
  CHECK(big.out.find("10000000 nodes") != std::string::npos);
  CHECK(big.err.find("would need about") != std::string::npos);
  CHECK(big.err.find("world.memory_limit") != std::string::npos);
}

TEST_CASE("haustra run: bad input exits with code 2 and names the file and line") {
  const Result r = run("run " + kCliScenes + "ropes.toml --set segment[2].radius=25");
  CHECK(r.code == 2);
  CHECK(r.err.find("ropes.toml") != std::string::npos);
  CHECK(r.err.find("segment[2].radius") != std::string::npos);
  CHECK(r.err.find("millimetres") != std::string::npos);
  CHECK(run("run /nonexistent.toml").code != 0);
  CHECK(run("fly").code != 0);
}

TEST_CASE("haustra run: an instability exits with code 3, says why, and still writes the summary") {
  const fs::path dir = out_dir("unstable");
  // PL²/B = 30: the lagged fixed-point iteration wanders instead of converging.
  const Result r = run("run " + kCliScenes +
                       "cantilever.toml --quiet --set solver.mode=lagged --set "
                       "solver.on_instability=stop --set \"segment.load[0].force=[0,0,-1.884955592e-05]\" --out " +
                       dir.string());
  CHECK(r.code == 3);
  CHECK(r.err.find("unstable at frame") != std::string::npos);
  CHECK(r.err.find("segment 'rod'") != std::string::npos);
  const auto j = summary(dir);
  CHECK(j["status"] == "unstable");
  REQUIRE_FALSE(j["events"].empty());
  CHECK(j["events"].back()["kind"] == "unstable");
  for (const auto& p : j["segments"][0]["final_node_positions_m"])
    for (const auto& c : p) CHECK(std::isfinite(c.get<double>()));
}

TEST_CASE("haustra validate --json reports every case, all passing") {
  const Result r = run("validate --json");
  REQUIRE(r.code == 0);
  const auto j = nlohmann::json::parse(r.out);
  REQUIRE(j.is_array());
  CHECK(j.size() >= 40);
  for (const auto& c : j) {
    INFO(c.dump());
    CHECK(c["pass"] == true);
    CHECK(c.contains("reference"));
    CHECK(c.contains("tolerance"));
  }
}

TEST_CASE("haustra run SURFACE imports it with the defaults first, a line per phase, and runs it") {
  const fs::path dir = out_dir("surface");
  const Result r =
      run("run " + std::string(HAUSTRA_SOURCE_DIR) +
          "/tests/data/anatomy/HuBMAPVHM-00070-large-intestine-Appendix.obj --frames 5 --out " + dir.string());
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  for (const char* phase :
       {"import: read ", "import: repair: ", "import: organ: ", "import: centreline: ", "import: built"})
    CHECK(r.err.find(phase) != std::string::npos);
  CHECK(fs::exists(dir / "summary.json"));
  // Imported into a folder of its own, gone when the run ends.
  const std::size_t said = r.err.find("is now the scene ");
  REQUIRE(said != std::string::npos);
  const std::size_t from = said + std::string("is now the scene ").size();
  const fs::path scene = r.err.substr(from, r.err.find(" (", from) - from);
  CHECK(
      scene.parent_path().filename().string().starts_with("haustra-import-HuBMAPVHM-00070-large-intestine-Appendix-"));
  CHECK_FALSE(fs::exists(scene.parent_path()));
  // A surface that is not there: the usual bad-input exit.
  const Result missing = run("run " + (dir / "missing.obj").string());
  CHECK(missing.code == 2);
}

TEST_CASE("haustra run SURFACE stopped by SIGTERM or SIGINT leaves no scratch folder behind") {
  const fs::path dir = out_dir("surface-signal");
  fs::create_directories(dir);
  for (const int sig : {SIGTERM, SIGINT}) {
    // A copy under a name of this case's own, so its scratch folder is told from any other.
    const std::string stem = "signal-" + std::to_string(::getpid()) + "-" + std::to_string(sig);
    const fs::path surface = dir / (stem + ".obj");
    fs::copy_file(std::string(HAUSTRA_SOURCE_DIR) + "/tests/data/anatomy/HuBMAPVHM-00070-large-intestine-Appendix.obj",
                  surface, fs::copy_options::overwrite_existing);
    const std::string prefix = "haustra-import-" + stem + "-";
    auto scratch = [&] {
      for (const auto& e : fs::directory_iterator(fs::temp_directory_path()))
        if (e.path().filename().string().starts_with(prefix)) return e.path();
      return fs::path();
    };
    const std::string command = kCli + " run " + surface.string() + " --quiet --frames 1000000 >/dev/null 2>&1";
    const pid_t pid = ::fork();
    REQUIRE(pid >= 0);
    if (pid == 0) {
      ::execl("/bin/sh", "sh", "-c", ("exec " + command).c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Waits for the folder (the import makes it first thing), then sends the signal: in lockstep
    // with the child's progress, whatever the machine's speed.
    fs::path folder;
    int status = 0;
    while ((folder = scratch()).empty() && ::waitpid(pid, &status, WNOHANG) == 0) ::usleep(10'000);
    REQUIRE_FALSE(folder.empty());
    ::kill(pid, sig);
    REQUIRE(::waitpid(pid, &status, 0) == pid);
    CHECK(WIFSIGNALED(status));
    CHECK(WTERMSIG(status) == sig);  // ended by the signal, as before: only the folder went first
    CHECK_FALSE(fs::exists(folder));
  }
}

TEST_CASE("haustra run grasps and pulls the CT colon and writes its deformed mesh: files and an animated glTF") {
  const fs::path dir = out_dir("anatomy");
  const Result r = run("run " + kCliScenes + "anatomy-grasp.toml --frames 40 --mesh-every 20 --out " + dir.string());
  INFO(r.out << r.err);
  REQUIRE(r.code == 0);
  // The builder's report: cage size, rings, inflation, embedding, the skin (along the rod, the default).
  // 55 bead rings, 54 between them, one past the anal end where the surface runs on beyond the rod.
  CHECK(r.out.find("cage: 110 rings (55 bead, 54 middle, 1 past an end, 0 taken out)") != std::string::npos);
  CHECK(r.out.find("0 mesh vertices outside, 0 mesh edges crossing, 0 cage self-intersections") != std::string::npos);
  CHECK(r.out.find("along the rod: each vertex on the rod's frames either side of its own place") != std::string::npos);
  CHECK(r.out.find(" slots per vertex; rest error ") != std::string::npos);
  CHECK(r.out.find("grasping segment 0") != std::string::npos);
  // The skin's stretch over the rod's own at each vertex's place (decision 0121), measured at frames
  // 15, 30 and 40: 1.32x as the grasp starts lifting, no edge torn.
  CHECK(r.out.find("skin: worst edge ") != std::string::npos);
  const nlohmann::json skin = summary(dir)["skin"];
  CHECK(skin["measures"] == 3);
  CHECK(skin["worst_edge_stretch"].get<double>() > 1.05);
  CHECK(skin["worst_edge_stretch"].get<double>() < 2.0);
  CHECK(skin["edges_past_2x"] == 0);
  for (const char* f : {"frame_00000.ply", "frame_00020.ply", "frame_00040.ply"}) CHECK(fs::exists(dir / "mesh" / f));
  // The centreline and the beads of the same frames as CSV: a header, then 3 frames × 167 nodes
  // and 3 frames × 55 beads.
  auto lines = [](const fs::path& p) {
    std::ifstream in(p);
    std::string line;
    int n = 0;
    while (std::getline(in, line)) ++n;
    return n;
  };
  CHECK(lines(dir / "centreline.csv") == 1 + 3 * 167);
  CHECK(lines(dir / "beads.csv") == 1 + 3 * 55);
  // Each file and the animation load back through assimp with the mesh's vertex count; the
  // animation has one morph target per recorded frame, and the last differs from the first.
  Assimp::Importer importer;
  const aiScene* last = importer.ReadFile((dir / "mesh" / "frame_00040.ply").string(), 0);
  REQUIRE(last != nullptr);
  CHECK(last->mMeshes[0]->mNumVertices == 9958);
  CHECK(last->mMeshes[0]->mNumFaces == 19838);
  Assimp::Importer gltf;
  const aiScene* anim = gltf.ReadFile((dir / "mesh.glb").string(), 0);
  INFO(gltf.GetErrorString());
  REQUIRE(anim != nullptr);
  REQUIRE(anim->mNumMeshes == 1);
  const aiMesh* mesh = anim->mMeshes[0];
  CHECK(mesh->mNumVertices == 9958);
  CHECK(mesh->mNumAnimMeshes == 3);
  REQUIRE(anim->mNumAnimations == 1);
  REQUIRE(anim->mAnimations[0]->mNumMorphMeshChannels == 1);
  CHECK(anim->mAnimations[0]->mMorphMeshChannels[0]->mNumKeys == 3);
  double moved = 0.0;
  const aiAnimMesh* final_frame = mesh->mAnimMeshes[2];
  for (unsigned v = 0; v < mesh->mNumVertices; ++v)
    moved = std::max(moved, static_cast<double>((final_frame->mVertices[v] - mesh->mVertices[v]).Length()));
  MESSAGE("the grasped colon moved up to " << moved << " m over 40 frames");
  CHECK(moved > 0.02);
}
