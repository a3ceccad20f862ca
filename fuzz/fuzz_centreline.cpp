// Fuzz target: centreline JSON → the reader and its checks → the rest shape built from it.
#include <cstddef>
#include <cstdint>
#include <string>

#include "haustra/centreline.hpp"
#include "haustra/error.hpp"
#include "haustra/rest_shape.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const haustra::Centreline c = haustra::parse_centreline(text, "fuzz.json");
    if (c.points.size() > 20000) return 0;
    // An odd and an even node count take both interval layouts of the biarc construction.
    for (int nodes : {21, 40})
      haustra::rest_shape_from_centreline(c.points, nodes, Eigen::Vector3d::UnitY(), "fuzz.json");
  } catch (const haustra::Error&) {
  }
  return 0;
}
