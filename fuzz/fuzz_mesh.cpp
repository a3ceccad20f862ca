// Fuzz target: mesh bytes → a file → load_mesh, the engine's own path (assimp, then check_mesh).
// The first byte picks the format the file claims to be, so one corpus covers several readers.
#include <unistd.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "haustra/error.hpp"
#include "haustra/mesh_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const std::array<const char*, 4> kExtensions = {".obj", ".stl", ".off", ".glb"};
  const std::filesystem::path file = std::filesystem::temp_directory_path() /
                                     ("haustra-fuzz-mesh-" + std::to_string(::getpid()) + kExtensions[data[0] % 4]);
  {
    std::ofstream out(file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  try {
    const haustra::TriangleMesh mesh = haustra::load_mesh(file);
    (void)haustra::is_closed(mesh);
    (void)haustra::mesh_volume(mesh.vertices, mesh.triangles);
  } catch (const haustra::Error&) {
  }
  std::filesystem::remove(file);
  return 0;
}
