// The C API's load per metre (haustra_world_set_distributed_load, decision 0102), through its header:
// the same bits as a scene's [[segment.distributed_load]]; a wrong count, NULL and a non-finite value refused.
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include <unistd.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

namespace {

constexpr const char* kRod = R"(
[world]
dt = 0.01
threads = 1
gravity = [0.0, 0.0, 0.0]
[[segment]]
name = "rod"
nodes = 21
youngs_modulus = 1000000.0
[segment.rest]
length = 1.0
)";

haustra_world* world_of(const std::string& text, const char* tag) {
  const auto path =
      std::filesystem::temp_directory_path() / ("haustra-c-loads-" + std::to_string(::getpid()) + "-" + tag + ".toml");
  std::ofstream(path) << text;
  haustra_world* w = nullptr;
  const haustra_status s = haustra_world_create_from_scene(path.c_str(), 1, &w);
  std::filesystem::remove(path);
  REQUIRE_MESSAGE(s == HAUSTRA_OK, haustra_last_error());
  return w;
}

std::vector<double> positions(const haustra_world* w) {
  haustra_vec3_view v{};
  REQUIRE(haustra_world_node_positions(w, &v) == HAUSTRA_OK);
  std::vector<double> out;
  for (std::size_t k = 0; k < v.count; ++k) out.insert(out.end(), {v.x[k], v.y[k], v.z[k]});
  return out;
}

}  // namespace

TEST_CASE("C API: a load per metre set at run time steps as the scene's distributed_load") {
  haustra_world* called = world_of(kRod, "called");
  haustra_world* scened =
      world_of(std::string(kRod) + "[[segment.distributed_load]]\nforce = [0.0, 0.2, -0.1]\n", "scened");
  std::vector<double> per_metre(3 * 21);
  for (std::size_t k = 0; k < 21; ++k) per_metre[3 * k + 1] = 0.2, per_metre[3 * k + 2] = -0.1;
  REQUIRE(haustra_world_set_distributed_load(called, 0, 21, per_metre.data(), nullptr, 0) == HAUSTRA_OK);
  for (int f = 0; f < 10; ++f) {
    REQUIRE(haustra_world_step(called) == HAUSTRA_OK);
    REQUIRE(haustra_world_step(scened) == HAUSTRA_OK);
  }
  CHECK(positions(called) == positions(scened));
  CHECK(haustra_world_set_distributed_load(called, 0, 20, per_metre.data(), nullptr, 0) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::strstr(haustra_last_error(), "segment 'rod' has 21 nodes") != nullptr);
  CHECK(haustra_world_set_distributed_load(called, 0, 21, nullptr, nullptr, 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::strstr(haustra_last_error(), "force_per_length is NULL") != nullptr);
  per_metre[7] = std::numeric_limits<double>::quiet_NaN();
  CHECK(haustra_world_set_distributed_load(called, 0, 21, per_metre.data(), nullptr, 1) == HAUSTRA_INVALID_ARGUMENT);
  CHECK(std::strstr(haustra_last_error(), "is not finite") != nullptr);
  CHECK(haustra_world_set_distributed_load(called, 1, 21, per_metre.data(), nullptr, 0) == HAUSTRA_INVALID_ARGUMENT);
  haustra_world_destroy(called);
  haustra_world_destroy(scened);
}
