// The bad-input catalogue: every kind of input a user or host can get wrong — scene files,
// centrelines, organ and obstacle meshes, calls on a world — each fed to the engine and answered
// with an haustra::Error whose code a program can branch on and whose message names the file, the
// line or field and what was expected. Nothing here may crash or be accepted.
#include <doctest/doctest.h>

#include <sys/stat.h>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>

#include "haustra/error.hpp"
#include "haustra/scene.hpp"
#include "haustra/world.hpp"
#include "minimal_scene.hpp"

using namespace haustra;

namespace {

const std::filesystem::path kScenes = std::filesystem::path(HAUSTRA_SOURCE_DIR) / "scenes";

struct BadInput {
  std::string label;
  std::function<void()> attempt;
  ErrorCode code;
  std::vector<std::string> words;  // each must appear in the message
};

// Files the cases read, in a folder of this process's own.
class Scratch {
 public:
  Scratch() : dir_(std::filesystem::temp_directory_path() / ("haustra-bad-input-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir_);
  }
  ~Scratch() { std::filesystem::remove_all(dir_); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name, std::ios::binary) << text;
    return dir_ / name;
  }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  // A named pipe: opening it for reading would wait for a writer that never comes.
  std::filesystem::path fifo(const std::string& name) const {
    const std::filesystem::path p = dir_ / name;
    if (!std::filesystem::exists(p)) ::mkfifo(p.c_str(), 0600);
    return p;
  }

 private:
  std::filesystem::path dir_;
};

constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr double inf = std::numeric_limits<double>::infinity();

using test::kMinimalScene;

BadInput scene(const std::string& text, std::vector<std::string> words, ErrorCode code = ErrorCode::parse) {
  return {"scene:\n" + text, [text] { create_world(parse_scene(text, kScenes / "test.toml")); }, code,
          std::move(words)};
}

// A scene in the scratch folder (so the files it names are found there).
BadInput scene_in(const Scratch& s, const std::string& text, ErrorCode code, std::vector<std::string> words) {
  const std::filesystem::path file = s.dir() / "scene.toml";
  return {"scene:\n" + text, [text, file] { create_world(parse_scene(text, file)); }, code, std::move(words)};
}

// A segment whose rest shape is the centreline in `json`.
BadInput centreline(const Scratch& s, const std::string& name, const std::string& json, ErrorCode code,
                    std::vector<std::string> words) {
  s.write(name, json);
  words.push_back(name);
  return scene_in(s, "[[segment]]\nnodes = 21\n[segment.rest]\nshape = \"centreline\"\nfile = \"" + name + "\"\n", code,
                  std::move(words));
}

// An open tube of radius r around the z axis from z = 0 to `length`, as OBJ text.
std::string tube_obj(double r, double length, int rings = 12, int around = 12) {
  std::string obj;
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < around; ++j) {
      const double a = 2.0 * 3.14159265358979 * j / around;
      obj += "v " + std::to_string(r * std::cos(a)) + " " + std::to_string(r * std::sin(a)) + " " +
             std::to_string(length * i / (rings - 1)) + "\n";
    }
  for (int i = 0; i + 1 < rings; ++i)
    for (int j = 0; j < around; ++j) {
      const int a = i * around + j + 1, b = i * around + (j + 1) % around + 1;
      const int c = a + around, d = b + around;
      obj += "f " + std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + "\n";
      obj += "f " + std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(c) + "\n";
    }
  return obj;
}

// A straight segment along z with beads, whose organ mesh is the file `name` holding `obj`.
BadInput organ_mesh(const Scratch& s, const std::string& name, const std::string& obj, ErrorCode code,
                    std::vector<std::string> words, const std::string& extra = "") {
  s.write(name, obj);
  words.push_back(name);
  return scene_in(s,
                  "[[segment]]\nnodes = 21\nradius = 0.02\n[segment.rest]\nlength = 0.2\n[segment.beads]\ncount = 11\n"
                  "[segment.mesh]\nfile = \"" +
                      name + "\"\n" + extra,
                  code, std::move(words));
}

// A scene file read from `path` (the readers' own file checks: kind, size).
BadInput scene_file(const std::filesystem::path& path, ErrorCode code, std::vector<std::string> words) {
  return {"scene file " + path.string(), [path] { create_world(load_scene(path)); }, code, std::move(words)};
}

// `open` repeated `levels` times, then `close` as often: nesting past every parser's stack.
std::string nested(const std::string& open, const std::string& inner, const std::string& close, int levels) {
  std::string text;
  for (int i = 0; i < levels; ++i) text += open;
  text += inner;
  for (int i = 0; i < levels; ++i) text += close;
  return text;
}

// A glTF binary holding `json` and no buffer: what assimp's glTF reader takes first.
std::string glb(std::string json) {
  json.append((4 - json.size() % 4) % 4, ' ');
  auto u32 = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  return "glTF" + u32(2) + u32(static_cast<std::uint32_t>(20 + json.size())) +
         u32(static_cast<std::uint32_t>(json.size())) + "JSON" + json;
}

// glTF nodes as a chain of `count` (each the child of the one before), or with the children given.
std::string gltf_nodes(const std::string& nodes) {
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[)" + nodes + "]}";
}
std::string node_chain(int count) {
  std::string nodes;
  for (int i = 0; i + 1 < count; ++i) nodes += "{\"children\":[" + std::to_string(i + 1) + "]},";
  return gltf_nodes(nodes + "{}");
}

// A call on a world built from the `demo` scene's shape, small: one segment with beads, a mesh,
// an attachment and an instrument.
std::unique_ptr<World> small_world() {
  const std::string text = std::string(kMinimalScene) +
                           "[segment.beads]\ncount = 6\n[segment.mesh]\nsource = \"procedural\"\n"
                           "[segment.mesh.procedural]\nvertices = 2000\n[[segment.attachment]]\nnode = -1\n"
                           "[[instrument]]\nname = \"grasper\"\n";
  return create_world(parse_scene(text, kScenes / "test.toml"));
}

BadInput call(const std::string& label, std::function<void(World&)> f, std::vector<std::string> words,
              ErrorCode code = ErrorCode::invalid_argument) {
  return {"call: " + label,
          [f] {
            auto w = small_world();
            f(*w);
          },
          code, std::move(words)};
}

// One function of ~190 lines on purpose: a table, one bad input per entry with the words its error
// must contain; split, the catalogue could not be read down in one pass.
std::vector<BadInput> catalogue(const Scratch& s) {
  const std::string m = kMinimalScene;
  std::vector<BadInput> cases = {
      // Scene files: syntax, unknown keys, types, ranges, units, missing fields.
      scene("[scene\nname = 1", {"test.toml:1", "not valid TOML"}),
      scene(m + "\n[world]\ndtt = 0.01\n", {"test.toml:11:1", "world.dtt", "unknown key", "dt, gravity, threads"}),
      scene(m + "\n[world]\ndt = \"fast\"\n", {"test.toml:11", "world.dt", "expected a number", "\"fast\""}),
      scene(m + "\n[world]\ndt = -0.1\n", {"test.toml:11", "world.dt", "positive"}, ErrorCode::invalid_argument),
      scene(m + "\n[world]\ndt = nan\n", {"world.dt", "finite"}),
      scene(m + "\n[world]\ndt = 5.0\n", {"world.dt", "plausible maximum 1"}, ErrorCode::invalid_argument),
      scene(m + "\n[world]\ngravity = [0, 0]\n", {"world.gravity", "expected [x, y, z]"}),
      scene(m + "\n[solver]\nmode = \"quick\"\n", {"test.toml:11", "solver.mode", "\"newton\", \"lagged\", \"fast\"", "\"quick\""}),
      scene(m + "\n[solver]\niterations = 0\n", {"test.toml:11", "solver.iterations", "[1, 10000]"}, ErrorCode::invalid_argument),
      scene(m + "\n[solver]\nrelaxation = 1.5\n", {"solver.relaxation", "(0, 1]"}, ErrorCode::invalid_argument),
      scene(m + "\n[solver]\niterations = 2.5\n", {"solver.iterations", "expected an integer"}),
      scene(m + "\n[filter]\nenabled = 1\n", {"filter.enabled", "expected true or false"}),
      scene("[[segment]]\nnodes = 1\n", {"test.toml:2", "segment[0].nodes", "[2, 10000000]"}, ErrorCode::invalid_argument),
      scene("[[segment]]\nradius = 20\n", {"test.toml:2", "segment[0].radius", "millimetres"}, ErrorCode::invalid_argument),
      scene("[[segment]]\nradius = 0.01\nwall_thickness = 0.02\n", {"test.toml:3", "segment[0].wall_thickness", "thicker than the radius"}, ErrorCode::invalid_argument),
      scene("[[segment]]\nyoungs_modulus = 0\n", {"test.toml:2", "segment[0].youngs_modulus", "positive"}, ErrorCode::invalid_argument),
      scene("[[segment]]\npoisson_ratio = 0.5\n", {"segment[0].poisson_ratio", "Poisson"}, ErrorCode::invalid_argument),
      scene("[[segment]]\nbase = \"floating\"\n", {"segment[0].base", "\"clamped\", \"free\""}),
      scene("[[segment]]\nbase = \"free\"\ndrag = 0\n", {"segment[0].drag", "a free base needs"}, ErrorCode::invalid_argument),
      scene("[[segment]]\nname = \"a\"\n[[segment]]\nname = \"a\"\n", {"segment[1].name", "used twice"}, ErrorCode::invalid_argument),
      scene("[[segment]]\n[segment.rest]\nshape = \"centreline\"\n", {"segment[0].rest.file", "needs file"}),
      scene("[[segment]]\n[segment.rest]\nshape = \"centreline\"\nfile = \"missing.json\"\n", {"test.toml:4", "missing.json", "cannot open"}, ErrorCode::io),
      scene("[[segment]]\n[segment.rest]\nfile = \"x.json\"\n", {"segment[0].rest.file", "only a rest shape with shape = \"centreline\""}),
      scene("[[segment]]\n[segment.rest]\nlength = 0\n", {"test.toml:3", "segment[0].rest.length", "positive"}, ErrorCode::invalid_argument),
      scene("[[segment]]\n[segment.rest]\ncurvature = [1, 2, 3]\n", {"segment[0].rest.curvature", "expected [a, b]"}),
      scene("[[segment]]\n[segment.law]\nbending = \"plastic\"\n", {"segment[0].law.bending", "\"kelvin-voigt\""}),
      scene("[[segment]]\n[segment.mesh]\nrings_per_vertex = 4\n", {"test.toml:3", "segment[0].mesh.rings_per_vertex", "removed (decision 0120)", "mesh.skinning = \"along-rod\" | \"cage\" | \"cage-full\" | \"linear-blend\""}),
      scene("[[segment]]\n[segment.mesh]\nweight_left_out = 0.02\n", {"test.toml:3", "segment[0].mesh.weight_left_out", "removed (decision 0120)", "mesh.skinning = \"along-rod\" | \"cage\" | \"cage-full\" | \"linear-blend\""}),
      scene("[[segment]]\n[segment.mesh]\nmax_rings_per_vertex = 7\n", {"test.toml:3", "segment[0].mesh.max_rings_per_vertex", "removed (decision 0120)", "mesh.skinning = \"along-rod\" | \"cage\" | \"cage-full\" | \"linear-blend\""}),
      scene("[[segment]]\n[segment.mesh]\nmean_rings_per_vertex = 7\n", {"test.toml:3", "segment[0].mesh.mean_rings_per_vertex", "removed (decision 0120)", "mesh.skinning = \"along-rod\" | \"cage\" | \"cage-full\" | \"linear-blend\""}),
      scene("[[segment]]\n[segment.mesh]\nskin_cost_limit = 2\n", {"test.toml:3", "segment[0].mesh.skin_cost_limit", "removed (decision 0120)", "mesh.skinning = \"along-rod\" | \"cage\" | \"cage-full\" | \"linear-blend\""}),
      scene("[[segment]]\n[segment.mesh]\nskinning = \"mvc\"\n", {"test.toml:3", "segment[0].mesh.skinning", "renamed", "skinning = \"cage\""}),
      scene("[[segment]]\n[segment.mesh]\nskinning = \"rigid\"\n", {"test.toml:3", "segment[0].mesh.skinning", "\"along-rod\", \"cage\", \"cage-full\", \"linear-blend\"", "\"rigid\""}),
      scene("[[segment]]\n[[segment.attachment]]\nhold_frame = true\n", {"segment[0].attachment[0].node", "needs node"}),
      scene("[[segment]]\nnodes = 5\n[[segment.attachment]]\nnode = 9\n", {"test.toml:4", "segment[0].attachment[0].node", "[-5, 4]"}, ErrorCode::invalid_argument),
      scene("[[segment]]\n[[segment.attachment]]\nnode = 0\n", {"segment[0].attachment[0].node", "clamped segment"}, ErrorCode::invalid_argument),
      scene("[[segment]]\n[[segment.attachment]]\nnode = 3\n[[segment.attachment]]\nnode = 3\n", {"attachment[1].node", "already attached"}, ErrorCode::invalid_argument),
      scene("[[segment]]\n[[segment.load]]\nnode = 2\nforce = [1, 2]\n", {"segment[0].load[0].force", "expected [x, y, z]"}),
      scene("[[segment]]\n[[segment.load]]\nforce = [1, 2, 3]\n", {"segment[0].load[0].node", "needs node"}),
      scene("[[segment]]\nnode = 5\n", {"segment[0].node", "unknown key", "nodes"}),
      scene("[scenery]\n", {"scenery", "unknown key", "scene, world, solver, filter, sleep, segment"}),
      scene("segment = 3\n", {"segment", "expected [[segment]] tables"}),
      scene("[scene]\nframes = -1\n", {"scene.frames", "non-negative"}),
      scene("[sleep]\nspeed = -0.001\n", {"sleep.speed", "m/s"}, ErrorCode::invalid_argument),
      scene("[sleep]\ntime = -1\n", {"sleep.time", "seconds at rest"}, ErrorCode::invalid_argument),
      scene("[sleep]\nafter = 2\n", {"sleep.after", "unknown key", "enabled, speed, time"}),
      // Contacts, beads, the environment and instruments.
      scene(m + "\n[contact]\ncoefficient = -5\n", {"test.toml:11", "contact.coefficient", "positive"}, ErrorCode::invalid_argument),
      scene(m + "\n[contact]\nexponent = 7\n", {"test.toml:11", "contact.exponent", "[1, 4]"}, ErrorCode::invalid_argument),
      scene(m + "\n[contact]\nbroad_phase = \"octree\"\n", {"contact.broad_phase", "\"grid\"", "\"octree\""}),
      scene(m + "\n[contact]\nstiffness = 1\n", {"contact.stiffness", "unknown key", "coefficient"}),
      scene(m + "\n[contact]\nrest_exclusions = \"all\"\n", {"contact.rest_exclusions", "\"world\"", "\"all\""}),
      scene(m + "[segment.beads]\ncount = 5\nspacing = 0.1\n", {"segment[0].beads", "one of them"}, ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\ncount = 50\n", {"test.toml:10", "segment[0].beads.count", "at most one bead per node"}, ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\nnodes = [0, 4, 40]\n", {"segment[0].beads.nodes[2]", "[-11, 10]", "40"}, ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\nradius = 15\n", {"test.toml:10", "segment[0].beads.radius", "millimetres"}, ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\nradius_profile = [[0.5, 0.02], [0.2, 0.01]]\n", {"radius_profile[1]", "rise from 0 to 1"}, ErrorCode::invalid_argument),
      scene(m + "\n[[environment.plane]]\nnormal = [0, 0, 0]\n", {"test.toml:11", "environment.plane[0].normal", "non-zero"}, ErrorCode::invalid_argument),
      scene(m + "\n[[environment.sphere]]\nradius = -1\n", {"environment.sphere[0].radius", "positive radius"}, ErrorCode::invalid_argument),
      scene(m + "\n[[environment.capsule]]\na = [0, 0]\n", {"environment.capsule[0].a", "expected [x, y, z]"}),
      scene(m + "\n[[environment.mesh]]\nname = \"pelvis\"\n", {"environment.mesh[0].file", "needs file"}),
      scene(m + "\n[[environment.mesh]]\nfile = \"no-such.obj\"\n", {"test.toml:11", "environment.mesh[0].file", "no-such.obj"}, ErrorCode::io),
      scene(m + "\n[[environment.mesh]]\nfile = \"assets/bolster.obj\"\nscale = 0\n", {"environment.mesh[0].scale", "positive scale"}),
      scene(m + "\n[environment]\nbox = 1\n", {"environment.box", "unknown key", "plane, sphere, capsule, mesh"}),
      scene(m + "\n[[environment.mesh]]\nfile = \"assets/bolster.obj\"\ncontainer = 1\n", {"environment.mesh[0].container", "true or false"}),
      scene(m + "\n[[instrument]]\nradius = 4\n", {"test.toml:11", "instrument[0].radius", "millimetres"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\naxis = [0, 0, 0]\n", {"instrument[0].axis", "non-zero"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\n[[instrument.keyframe]]\ntip = [0, 0, 1]\n", {"instrument[0].keyframe[0].time", "needs time"}),
      scene(m + "\n[[instrument]]\n[[instrument.keyframe]]\ntime = 1.0\n[[instrument.keyframe]]\ntime = 0.5\n", {"instrument[0].keyframe[1].time", "increasing time"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\ngrasp_reach = -0.01\n", {"instrument[0].grasp_reach", "[0, 0.5]"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\ncoupling_stiffness = -1.0\n", {"instrument[0].coupling_stiffness", "rigid grasp"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\nforce_limit = 0.0\n", {"instrument[0].force_limit", "(0, 1e5]"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\nholding_force = -2\n", {"instrument[0].holding_force", "never slips"}, ErrorCode::invalid_argument),
      scene(m + "\n[solver]\nmax_iterations = 0\n", {"solver.max_iterations", "[1, 10000]"}, ErrorCode::invalid_argument),
      scene(m + "\n[solver]\nattachment_tolerance = 1e-5\n", {"test.toml:11", "solver.attachment_tolerance", "removed in decision 0108"}),
      scene(m + "\n[solver]\nprefactor = true\n", {"test.toml:11", "solver.prefactor", "removed in decision 0108"}),
      // Centrelines.
      centreline(s, "c-text.json", "[0, 0, 0]", ErrorCode::parse, {"expected a JSON object"}),
      centreline(s, "c-broken.json", "{\"units\": \"mm\", \"points\": [[0, 0, 0]", ErrorCode::parse, {"not valid JSON"}),
      centreline(s, "c-units.json", "{\"units\": \"inch\", \"points\": [[0,0,0],[0,0,1]]}", ErrorCode::parse,
                 {"units", "\"mm\", \"cm\" or \"m\"", "\"inch\""}),
      centreline(s, "c-nounits.json", "{\"points\": [[0,0,0],[0,0,1]]}", ErrorCode::parse, {"'units'"}),
      centreline(s, "c-point.json", "{\"units\": \"m\", \"points\": [[0,0,0],[0,1]]}", ErrorCode::parse,
                 {"points[1]", "expected [x, y, z]"}),
      centreline(s, "c-string.json", "{\"units\": \"m\", \"points\": [[0,0,0],[0,\"a\",1]]}", ErrorCode::parse,
                 {"points[1]", "expected numbers"}),
      centreline(s, "c-one.json", "{\"units\": \"m\", \"points\": [[0,0,0]]}", ErrorCode::invalid_geometry,
                 {"at least 2 points, got 1"}),
      centreline(s, "c-empty.json", "{\"units\": \"m\", \"points\": []}", ErrorCode::invalid_geometry,
                 {"at least 2 points, got 0"}),
      centreline(s, "c-repeat.json", "{\"units\": \"m\", \"points\": [[0,0,0],[0,0,0.1],[0,0,0.1],[0,0,0.2]]}",
                 ErrorCode::invalid_geometry, {"points 1 and 2 are the same point"}),
      centreline(s, "c-zero.json", "{\"units\": \"m\", \"points\": [[0,0,0],[0,0,0]]}", ErrorCode::invalid_geometry,
                 {"same point"}),
      centreline(s, "c-cusp.json", "{\"units\": \"m\", \"points\": [[0,0,0],[0,0,0.1],[0,0.001,0]]}",
                 ErrorCode::invalid_geometry, {"reverses at point 1", "cusp"}),
      centreline(s, "c-cross.json",
                 "{\"units\": \"m\", \"points\": [[0,0,0],[0.1,0.1,0],[0.1,0,0],[0,0.1,0]]}",
                 ErrorCode::invalid_geometry, {"crosses itself", "segment 0–1", "segment 2–3"}),
      centreline(s, "c-huge.json", "{\"units\": \"m\", \"points\": [[0,0,0],[0,0,1e400]]}", ErrorCode::parse,
                 {"not valid JSON"}),
      scene_in(s, "[[segment]]\n[segment.rest]\nshape = \"centreline\"\nfile = \"nowhere.json\"\n", ErrorCode::io,
               {"scene.toml:4", "nowhere.json", "cannot open"}),
      // Organ meshes.
      organ_mesh(s, "m-empty.obj", "# nothing\n", ErrorCode::parse, {"segment[0].mesh.file"}),
      organ_mesh(s, "m-points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", ErrorCode::parse, {"segment[0].mesh.file"}),
      organ_mesh(s, "m-index.obj", "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 2 9\n", ErrorCode::parse,
                 {"segment[0].mesh.file", "m-index.obj:4", "face index \"9\" names no vertex: the file has 3"}),
      organ_mesh(s, "m-short.obj", "v 0 0 0\nv 0.01 0\nv 0 0.01 0\nf 1 2 3\n", ErrorCode::parse,
                 {"segment[0].mesh.file", "m-short.obj:2", "vertex 2 needs three numbers"}),
      organ_mesh(s, "m-word.obj", "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 two 3\n", ErrorCode::parse,
                 {"m-word.obj:4", "face index \"two\""}),
      organ_mesh(s, "m-repeat.obj", tube_obj(0.015, 0.2) + "f 1 1 2\n", ErrorCode::invalid_geometry,
                 {"segment[0].mesh.file", "repeats a vertex", "degenerate"}),
      organ_mesh(s, "m-sliver.obj", tube_obj(0.015, 0.2) + "v 0.5 0.5 0.5\nv 0.6 0.6 0.6\nv 0.7 0.7 0.7\nf 145 146 147\n",
                 ErrorCode::invalid_geometry, {"triangle 264", "has no area"}),
      organ_mesh(s, "m-fin.obj", tube_obj(0.015, 0.2) + "v 0 0 0.5\nf 13 14 145\n", ErrorCode::invalid_geometry,
                 {"(0.015, 0, 0.01818)", "(0.01299, 0.0075, 0.01818)", "shared by 3 triangles", "not a manifold"}),
      organ_mesh(s, "m-flip.obj", tube_obj(0.015, 0.2) + "v 0 0 -0.01\nf 1 2 145\n", ErrorCode::invalid_geometry,
                 {"run the same way", "winding is inconsistent"}),
      organ_mesh(s, "m-nan.obj", "v nan 0 0\nv 0.01 0 0\nv 0 0.01 0\nf 1 2 3\n", ErrorCode::invalid_geometry,
                 {"vertex 0 is not finite"}),
      organ_mesh(s, "m-away.obj", tube_obj(0.015, 0.2), ErrorCode::invalid_geometry,
                 {"segment[0].mesh", "lies", "from the rod", "translate"}, "translate = [1.0, 0.0, 0.0]\n"),
      organ_mesh(s, "m-mm.obj", tube_obj(15, 200), ErrorCode::invalid_geometry,
                 {"segment[0].mesh", "from the rod", "in metres (scale)"}),
      scene_in(s, "[[segment]]\nnodes = 21\n[segment.beads]\ncount = 11\n[segment.mesh]\nfile = \"m-away.obj\"\nscale = -1.0\n",
               ErrorCode::invalid_argument, {"scene.toml:7", "segment[0].mesh.scale", "positive scale"}),
      organ_mesh(s, "m-noface.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 3 2\n", ErrorCode::parse,
                 {"segment[0].mesh.file", "cannot read the mesh"}),  // found by fuzzing: assimp aborted
      organ_mesh(s, "m-tetra.ply", "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n", ErrorCode::invalid_argument,
                 {"'.ply' meshes are not read", ".obj, .stl, .off, .gltf, .glb"}),  // assimp's PLY reader hangs
      organ_mesh(s, "m-claims.off", "OFF\n40000000000 4 0\n0 0 0\n1 0 0\n", ErrorCode::parse,
                 {"claims 4e+10 vertices and 4 faces", "bytes can hold"}),  // found by fuzzing: a 45 GB allocation
      organ_mesh(s, "m-text.obj", "this is not a mesh\n\x01\x02", ErrorCode::parse,
                 {"segment[0].mesh.file", "cannot read the mesh", "At least one mesh"}),
      scene_in(s, "[[segment]]\nnodes = 21\n[segment.beads]\ncount = 11\n[segment.mesh]\nfile = \"absent.obj\"\n",
               ErrorCode::io, {"scene.toml:6", "absent.obj", "no such mesh file"}),
      {"a mesh file larger than the engine reads",
       [&s] {
         const std::filesystem::path big = s.dir() / "m-huge.obj";
         std::ofstream(big).put('#');
         std::filesystem::resize_file(big, (std::uintmax_t{3} << 30));  // sparse: no disk used
         create_world(parse_scene("[[segment]]\nnodes = 21\n[segment.beads]\ncount = 11\n[segment.mesh]\nfile = \"m-huge.obj\"\n",
                                  s.dir() / "scene.toml"));
       },
       ErrorCode::invalid_argument, {"m-huge.obj", "3.0 GiB", "decimate"}},
      scene_in(s, "[[segment]]\nnodes = 21\n[segment.mesh]\nsource = \"procedural\"\n", ErrorCode::invalid_argument,
               {"segment[0].mesh", "at least two beads"}),
      // Obstacle meshes.
      scene_in(s, "[[segment]]\n[[environment.mesh]]\nfile = \"m-fin.obj\"\n", ErrorCode::invalid_geometry,
               {"scene.toml:3", "environment.mesh[0].file", "not a manifold"}),
      scene_in(s, "[[segment]]\n[[environment.mesh]]\nfile = \"m-away.obj\"\ncontainer = true\n", ErrorCode::invalid_geometry,
               {"scene.toml:4", "environment.mesh[0].container", "m-away.obj is not closed", "closed surface"}),
      // Inputs past the readers' bounds (decision 0098): nesting that overflowed a parser's stack,
      // files that are not regular (blocked or never ended), files too large.
      scene("[" + nested("a.", "a", "", 100'000) + "]\n", {"test.toml:1:1", "nests more than 64 levels deep"},
            ErrorCode::invalid_argument),  // 200 KB: toml++ overflowed its stack
      scene("x = " + nested("[", "", "]", 300) + "\n", {"test.toml:1:68", "nests more than 64"}, ErrorCode::invalid_argument),
      scene("x = " + nested("{a = ", "1", "}", 300) + "\n", {"test.toml:1:", "nests more than 64"},
            ErrorCode::invalid_argument),
      {"a --set value nested past the limit",
       [] {
         const std::vector<std::string> sets{"segment.radius=" + nested("[", "", "]", 100)};
         create_world(parse_scene(kMinimalScene, kScenes / "test.toml", sets));
       },
       ErrorCode::invalid_argument, {"test.toml (--set segment.radius)", "nests more than 64"}},
      centreline(s, "c-deep.json", "{\"units\": \"m\", \"points\": " + nested("[", "", "]", 20'000) + "}",
                 ErrorCode::invalid_argument, {"scene.toml:5", "c-deep.json:1:", "nests more than 64 levels"}),
      centreline(s, "c-long-point.json", "{\"units\": \"m\", \"points\": [" + nested("[", "0", "]", 30) + "]}",
                 ErrorCode::parse, {"points[0]", "expected [x, y, z], got an array of 1 entry"}),
      scene_file("/dev/zero", ErrorCode::io, {"/dev/zero: a character device, not a scene file", "regular files only"}),
      scene_file(s.dir(), ErrorCode::io, {"a folder, not a scene file"}),
      scene_file(s.fifo("pipe.toml"), ErrorCode::io, {"pipe.toml: a FIFO (named pipe), not a scene file"}),
      {"a scene file larger than a scene may be",
       [&s] {
         const std::filesystem::path big = s.write("big.toml", "# a scene\n");
         std::filesystem::resize_file(big, (std::uintmax_t{17} << 20));  // sparse: no disk used
         create_world(load_scene(big));
       },
       ErrorCode::invalid_argument, {"big.toml: 17825792 bytes, more than the 16 MiB a scene file may have"}},
      scene_in(s, "[[segment]]\nnodes = 21\n[segment.rest]\nshape = \"centreline\"\nfile = \"" +
                      s.fifo("pipe.json").filename().string() + "\"\n",
               ErrorCode::io, {"scene.toml:5", "pipe.json: a FIFO (named pipe), not a centreline file"}),
      organ_mesh(s, "m-deep.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"extras\": " + nested("[", "", "]", 5'000) + "}",
                 ErrorCode::invalid_argument, {"segment[0].mesh.file", "m-deep.gltf:1:", "nests more than 64"}),
      organ_mesh(s, "m-chain.glb", glb(node_chain(300)), ErrorCode::invalid_argument,
                 {"glTF node 256 lies 257 levels deep in the node hierarchy, more than 256"}),
      organ_mesh(s, "m-cycle.glb", glb(gltf_nodes(R"({"children":[1]},{"children":[0]})")), ErrorCode::invalid_argument,
                 {"glTF node 0 is its own ancestor"}),
      organ_mesh(s, "m-parents.glb", glb(gltf_nodes(R"({"children":[2]},{"children":[2]},{})")), ErrorCode::invalid_argument,
                 {"glTF node 2 has two parents"}),
      {"a mesh file that is a FIFO",
       [&s] {
         s.fifo("pipe.obj");
         create_world(parse_scene("[[segment]]\nnodes = 21\n[segment.beads]\ncount = 11\n[segment.mesh]\nfile = \"pipe.obj\"\n",
                                  s.dir() / "scene.toml"));
       },
       ErrorCode::io, {"scene.toml:6", "pipe.obj: a FIFO (named pipe), not a mesh file"}},
      call("a checkpoint read from a device", [](World& w) { w.restore_checkpoint_file("/dev/zero"); },
           {"/dev/zero: a character device, not a checkpoint"}, ErrorCode::io),
      // Values no step can hold, refused where they are set with the field named (decision 0098).
      scene(m + "\n[world]\ndt = 5e-324\n", {"test.toml:11", "world.dt: 5e-324 s is below the plausible minimum 1e-06 s"},
            ErrorCode::invalid_argument),
      scene("[[segment]]\nyoungs_modulus = 1e-300\n", {"test.toml:2", "segment[0].youngs_modulus", "plausible minimum 1 Pa"},
            ErrorCode::invalid_argument),
      scene("[[segment]]\n[segment.rest]\nlength = 1e-300\n", {"test.toml:3", "segment[0].rest.length", "plausible minimum 0.001 m"},
            ErrorCode::invalid_argument),
      scene(m + "\n[[environment.plane]]\npoint = [0.0, 0.0, 1e300]\n", {"test.toml:11", "environment.plane[0].point", "beyond ±100000"},
            ErrorCode::invalid_argument),
      scene(m + "[[segment.load]]\nnode = -1\nforce = [0.0, 0.0, 1e30]\n", {"test.toml:11", "segment[0].load[0].force", "no step holds it"},
            ErrorCode::invalid_argument),
      call("a load of 1e30 N", [](World& w) { w.set_external_load(2, {1e30, 0.0, 0.0}, Eigen::Vector3d::Zero()); },
           {"within ±100000 in each component"}),
      // Every field bounded above and below as docs/scene-format.md states it (issue 36).
      scene(m + "\n[[instrument]]\nholding_force = 1e6\n",
            {"test.toml:11", "instrument[0].holding_force", "expected a force in [0, 100000] N"}, ErrorCode::invalid_argument),
      scene(m + "\n[[instrument]]\n[[instrument.keyframe]]\ntime = 1e300\n",
            {"test.toml:12", "instrument[0].keyframe[0].time", "within ±1e+09"}, ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\nspacing = 1e300\n", {"test.toml:10", "segment[0].beads.spacing", "(0, 1000] m"},
            ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\ncount = 5\n[segment.mesh]\n[segment.mesh.procedural]\nradius = 1e-300\n",
            {"test.toml:13", "segment[0].mesh.procedural.radius", "[0.0001, 0.5] m, got 1e-300"}, ErrorCode::invalid_argument),
      scene(m + "[segment.beads]\ncount = 5\n[segment.mesh]\n[segment.mesh.procedural]\nradius = -0.01\n",
            {"segment[0].mesh.procedural.radius", "got -0.01"}, ErrorCode::invalid_argument),
      scene(m + "\n[[environment.mesh]]\nfile = \"assets/bolster.obj\"\ntranslate = [1e300, 0.0, 0.0]\n",
            {"test.toml:12", "environment.mesh[0].translate", "within ±1e5 m"}),
      scene(m + "\n[[environment.mesh]]\nfile = \"assets/bolster.obj\"\nscale = 1e9\n",
            {"test.toml:12", "environment.mesh[0].scale", "up to 1e5"}),
      organ_mesh(s, "m-far.obj", tube_obj(0.015, 0.2), ErrorCode::invalid_argument,
                 {"segment[0].mesh.translate", "within ±100000 m"}, "translate = [1e300, 0.0, 0.0]\n"),
      organ_mesh(s, "m-vast.obj", tube_obj(2.0, 2.0), ErrorCode::invalid_argument,
                 {"segment[0].mesh.scale", "beyond ±100000 m"}, "scale = 1e5\n"),
      // Calls on a world.
      call("external load on a node that does not exist",
           [](World& w) { w.set_external_load(w.node_count(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()); },
           {"World::set_external_load: node index 11 out of range"}),
      call("a NaN force", [](World& w) { w.set_external_load(0, Eigen::Vector3d(nan, 0, 0), Eigen::Vector3d::Zero()); },
           {"finite"}),
      call("an infinite moment", [](World& w) { w.set_external_load(0, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, inf, 0)); },
           {"finite"}),
      call("an attachment that does not exist", [](World& w) { w.set_attachment_target(0, 5, Eigen::Vector3d::Zero()); },
           {"World::set_attachment_target: segment 'a' has 2 attachments, asked for index 5"}),
      call("an attachment of a segment that does not exist",
           [](World& w) { w.set_attachment_active(3, 0, false); }, {"World::set_attachment_active: segment index 3 out of range"}),
      call("a NaN attachment target", [](World& w) { w.set_attachment_target(0, 0, Eigen::Vector3d(0, nan, 0)); },
           {"finite"}),
      call("a zero attachment rotation",
           [](World& w) { w.set_attachment_target_rotation(0, 0, Eigen::Quaterniond(0, 0, 0, 0)); }, {"non-zero quaternion"}),
      call("an instrument that does not exist",
           [](World& w) { w.set_instrument_pose(1, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()); },
           {"World::set_instrument_pose: instrument index 1 out of range", "has 1"}),
      call("an instrument axis of zero length",
           [](World& w) { w.set_instrument_pose(0, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()); }, {"non-zero direction"}),
      call("reading an instrument that does not exist", [](World& w) { (void)w.instrument(7); }, {"World::instrument: instrument index 7"}),
      call("a rod pose with too few strains",
           [](World& w) { w.pose_rod(0, w.base_pose(0), std::vector<double>(5, 0.0)); }, {"needs 44 strains", "got 5"}),
      call("a rod pose with a NaN strain",
           [](World& w) {
             std::vector<double> q(44, 0.0);
             q[7] = nan;
             w.pose_rod(0, w.base_pose(0), q);
           },
           {"strains must be finite"}),
      call("the mesh of a segment that does not exist", [](World& w) { (void)w.mesh(2); }, {"World::mesh: segment index 2"}),
      call("the cage of a segment that does not exist", [](World& w) { (void)w.cage_vertices(9); }, {"World::cage_vertices: segment index 9"}),
      call("the base pose of a segment that does not exist", [](World& w) { (void)w.base_pose(4); }, {"World::base_pose: segment index 4"}),
      // Every accessor's range error names the call (the checks take their caller's location).
      call("the info of a segment that does not exist", [](World& w) { (void)w.segment(6); },
           {"World::segment: segment index 6 out of range"}),
      call("the chain of a segment that does not exist", [](World& w) { (void)w.chain_of(6); },
           {"World::chain_of: segment index 6"}),
      call("the beads of a segment that does not exist", [](World& w) { (void)w.beads(6); }, {"World::beads: segment index 6"}),
      call("the ring poses of a segment that does not exist", [](World& w) { (void)w.ring_poses(6); },
           {"World::ring_poses: segment index 6"}),
      call("the attachments of a segment that does not exist", [](World& w) { (void)w.attachment_count(6); },
           {"World::attachment_count: segment index 6"}),
      call("reading the load of a node that does not exist", [](World& w) { (void)w.external_load(w.node_count()); },
           {"World::external_load: node index 11 out of range"}),
      call("the coupling of an instrument that does not exist",
           [](World& w) { w.set_instrument_coupling(2, 1000.0, 2.0, 8.0); },
           {"World::set_instrument_coupling: instrument index 2 out of range"}),
      call("a bead with itself", [](World& w) { (void)w.beads_may_collide(1, 1); }, {"two different beads"}),
      {"a world description with an infinite time step",
       [] {
         WorldDesc d;
         d.dt = inf;
         World::create(d);
       },
       ErrorCode::invalid_argument, {"world.dt", "finite"}},
      {"a world description with a negative thread count",
       [] {
         WorldDesc d;
         d.threads = -3;
         d.segments.emplace_back();
         World::create(d);
       },
       ErrorCode::invalid_argument, {"threads", "-3"}},
  };
  return cases;
}

}  // namespace

TEST_CASE("bad-input catalogue: every case fails with its error code and a message naming what and where") {
  const Scratch scratch;
  const std::vector<BadInput> cases = catalogue(scratch);
  // Exactly the catalogue's cases: one lost in an edit (a list that silently shrinks) fails here;
  // a new case raises the count.
  CHECK(cases.size() == 168);
  for (const BadInput& c : cases) {
    INFO(c.label);
    std::string message;
    bool threw = false;
    try {
      c.attempt();
    } catch (const Error& e) {
      threw = true;
      message = e.what();
      INFO("message: " << message);
      CHECK_MESSAGE(e.code() == c.code, "code " << std::string(error_code_name(e.code())) << ", expected "
                                                << std::string(error_code_name(c.code)));
      for (const std::string& w : c.words) CHECK_MESSAGE(message.find(w) != std::string::npos, "missing: " << w);
    } catch (const std::exception& e) {
      threw = true;
      FAIL_CHECK("not a haustra::Error: " << e.what());
    }
    CHECK_MESSAGE(threw, "accepted");
  }
}
