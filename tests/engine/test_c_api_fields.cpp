// The C API's copies of the engine's reports (report_fields.h) against the C++ API's own: the same
// scene stepped through both, every field compared. (test_c_api.cpp uses the C header alone.)
#include <doctest/doctest.h>
#include <haustra/haustra.h>

#include <unistd.h>
#include "c_sized.hpp"

#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "haustra/scene.hpp"
#include "haustra/world.hpp"

using namespace haustra;

// The C profile's fields come from HAUSTRA_PROFILE_COUNTERS (haustra.h declares them from its two
// parts around `newton`); its layout is the ABI's, so a counter moved within the list, or added
// anywhere but at the end, fails here at compile time: each field at its ABI 15/16 offset.
#define HAUSTRA_COUNT_COUNTER(type, name, initial, meaning) +1
constexpr std::size_t kProfileInts = 1 + (0 HAUSTRA_PROFILE_COUNTERS(HAUSTRA_COUNT_COUNTER));
#undef HAUSTRA_COUNT_COUNTER
constexpr std::size_t kFirstInt = sizeof(size_t) + sizeof(double) * (HAUSTRA_STAGE_COUNT + 1);
static_assert(offsetof(haustra_profile, substeps) == kFirstInt);
static_assert(offsetof(haustra_profile, retries) == kFirstInt + 1 * sizeof(int));
static_assert(offsetof(haustra_profile, newton) == kFirstInt + 2 * sizeof(int));
static_assert(offsetof(haustra_profile, fallbacks) == kFirstInt + 3 * sizeof(int));
static_assert(offsetof(haustra_profile, backtracks) == kFirstInt + 4 * sizeof(int));
static_assert(offsetof(haustra_profile, stiffenings) == kFirstInt + 5 * sizeof(int));
static_assert(offsetof(haustra_profile, chords) == kFirstInt + 6 * sizeof(int));
static_assert(offsetof(haustra_profile, stalls) == kFirstInt + 7 * sizeof(int));
static_assert(offsetof(haustra_profile, iterations) == kFirstInt + 8 * sizeof(int));
static_assert(offsetof(haustra_profile, late) == kFirstInt + 9 * sizeof(int));
static_assert(offsetof(haustra_profile, nodes_asleep) == kFirstInt + 10 * sizeof(int));  // ABI 16
static_assert(sizeof(haustra_profile) == (kFirstInt + sizeof(int) * kProfileInts + alignof(haustra_profile) - 1) /
                                             alignof(haustra_profile) * alignof(haustra_profile));

TEST_CASE("every profile counter reaches the C API: the same scene stepped through both, field by field") {
  // The drop in fast mode (iterations, chords, the frames it falls back to Newton on), written to
  // a scene file of its own for the C API (which takes a file).
  std::ifstream in(std::string(HAUSTRA_SOURCE_DIR) + "/scenes/drop.toml");
  std::stringstream text;
  text << in.rdbuf();
  std::string toml = text.str();
  const std::size_t mode = toml.find("mode = \"newton\"");
  REQUIRE(mode != std::string::npos);
  toml.replace(mode, std::strlen("mode = \"newton\""), "mode = \"fast\"");
  const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("haustra-profile-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(file) << toml;
  auto w = create_world(load_scene(file));
  haustra_world* c = nullptr;
  REQUIRE(haustra_world_create_from_scene(file.c_str(), 1, &c) == HAUSTRA_OK);
  std::filesystem::remove(file);
  int chords = 0, iterations = 0;
  for (int f = 0; f < 30; ++f) {
    w->step();
    REQUIRE(haustra_world_step(c) == HAUSTRA_OK);
    const FrameProfile& p = w->last_profile();
    haustra_profile q = sized<haustra_profile>();
    REQUIRE(haustra_world_profile(c, &q) == HAUSTRA_OK);
#define HAUSTRA_CHECK_FIELD(type, name, initial, meaning) CHECK(q.name == p.name);
    HAUSTRA_PROFILE_COUNTERS(HAUSTRA_CHECK_FIELD)
#undef HAUSTRA_CHECK_FIELD
    CHECK(q.newton == (p.newton ? 1 : 0));
    chords += p.chords;
    iterations += p.iterations;
  }
  CHECK(chords > 0);  // the comparison saw counters that move
  CHECK(iterations > 0);
  CHECK(haustra_world_destroy(c) == HAUSTRA_OK);
}
