// Triangle meshes read and written through assimp.
#include "haustra/mesh_io.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <new>
#include <sstream>
#include <vector>

#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <map>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"

namespace haustra {
namespace {

// An OFF header states its counts up front and assimp allocates them before reading a vertex: a
// header claiming 10²⁷ faces (found by fuzzing) asked for 45 GB. Each vertex needs at least
// "0 0 0\n" and each face "3 0 1 2\n", so counts the file cannot hold are refused here.
void check_off_counts(const std::filesystem::path& file, std::uintmax_t bytes) {
  std::ifstream in(file);
  std::string word;
  in >> word;  // "OFF" (or a variant such as "COFF"), possibly fused with the counts
  if (!in || word.find("OFF") == std::string::npos) return;  // not an OFF header: the reader will say so
  double vertices = 0.0, faces = 0.0;
  if (!(in >> vertices >> faces)) return;
  if (!(vertices >= 0.0) || !(faces >= 0.0) || 6.0 * vertices + 8.0 * faces > static_cast<double>(bytes) + 64.0)
    throw Error(ErrorCode::parse, fmt::format("{}: the OFF header claims {:.6g} vertices and {:.6g} faces, more than "
                                              "its {} bytes can hold",
                                              file.string(), vertices, faces, bytes));
}

// An OBJ's vertices and faces, checked line by line before assimp reads it, so that an error names
// the line (assimp's say "index out of range" without one): a vertex needs three numbers, a face's
// indices must name vertices the file has (1-based, or negative from the last; a face may refer to
// vertices defined after it, as assimp allows). One pass to count the vertices, one to check.
void check_obj_lines(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::string line;
  long long vertices = 0;
  while (std::getline(in, line))
    if (line.size() > 1 && line[0] == 'v' && (line[1] == ' ' || line[1] == '\t')) ++vertices;
  in.clear();
  in.seekg(0);
  long long number = 0, seen = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.size() < 2 || (line[1] != ' ' && line[1] != '\t')) continue;
    if (line[0] == 'v') {
      ++seen;
      std::istringstream words(line.substr(2));
      std::string word;
      int numbers = 0;
      while (numbers < 3 && words >> word) {
        char* end = nullptr;
        (void)std::strtod(word.c_str(), &end);
        if (end == word.c_str() || *end != '\0') break;
        ++numbers;
      }
      if (numbers < 3)
        throw Error(ErrorCode::parse, fmt::format("{}:{}: vertex {} needs three numbers (x y z), got \"{}\"",
                                                  file.string(), number, seen, line.substr(0, 80)));
    } else if (line[0] == 'f') {
      std::istringstream words(line.substr(2));
      std::string word;
      while (words >> word) {
        const std::string index = word.substr(0, word.find('/'));
        char* end = nullptr;
        const long long k = std::strtoll(index.c_str(), &end, 10);
        if (end == index.c_str() || *end != '\0' || k == 0 || k > vertices || k < -vertices)
          throw Error(ErrorCode::parse,
                      fmt::format("{}:{}: face index \"{}\" names no vertex: the file has {} (1 to {}, or -1 to -{} "
                                  "from the last)",
                                  file.string(), number, index.substr(0, 40), vertices, vertices, vertices));
      }
    }
  }
}

// While alive, the importer knows only the readers of kMeshFormats. An extension alone does not
// choose the reader: when the named format's reader declines a file, assimp tries every reader on
// the content, so a file called .glb holding a PLY header would still reach the PLY reader (found
// by fuzzing). The readers taken out are given back before the importer is destroyed, which
// deletes them.
class AllowedReadersOnly {
 public:
  explicit AllowedReadersOnly(Assimp::Importer& importer) : importer_(importer) {
    for (std::size_t i = 0; i < importer.GetImporterCount(); ++i) {
      const aiImporterDesc* desc = importer.GetImporterInfo(i);
      std::istringstream extensions(desc != nullptr && desc->mFileExtensions != nullptr ? desc->mFileExtensions : "");
      bool allowed = false;
      for (std::string e; extensions >> e;)
        allowed = allowed || std::find(kMeshFormats.begin(), kMeshFormats.end(), "." + e) != kMeshFormats.end();
      if (!allowed) removed_.push_back(importer.GetImporter(i));
    }
    for (Assimp::BaseImporter* r : removed_) importer.UnregisterLoader(r);
  }
  ~AllowedReadersOnly() {
    for (Assimp::BaseImporter* r : removed_) importer_.RegisterLoader(r);
  }
  AllowedReadersOnly(const AllowedReadersOnly&) = delete;
  AllowedReadersOnly& operator=(const AllowedReadersOnly&) = delete;

 private:
  Assimp::Importer& importer_;
  std::vector<Assimp::BaseImporter*> removed_;
};

}  // namespace

TriangleMesh load_mesh_as_read(const std::filesystem::path& file) {
  // Only formats whose readers in Debian's assimp survive fuzzing (docs/decisions/0023).
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (std::find(kMeshFormats.begin(), kMeshFormats.end(), ext) == kMeshFormats.end())
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: '{}' meshes are not read; convert it to one of {} (assimp's PLY reader, for one, "
                            "hangs on malformed files)",
                            file.string(), ext, fmt::join(kMeshFormats, ", ")));
  std::error_code missing;
  if (!std::filesystem::exists(file, missing))
    throw Error(ErrorCode::io, fmt::format("{}: no such mesh file", file.string()));
  // A regular file (a FIFO would block assimp, a device feed it forever), of a size assimp may read.
  const std::uintmax_t bytes = io::regular_file_size(file, "mesh file", std::numeric_limits<std::uintmax_t>::max());
  if (bytes > kMaxMeshFileBytes)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: {:.1f} GiB, more than the {} GiB the engine reads as a mesh; decimate the mesh",
                            file.string(), static_cast<double>(bytes) / (1 << 30), kMaxMeshFileBytes >> 30));
  Assimp::Importer importer;
  const AllowedReadersOnly allowed(importer);
  // Validation first: Debian's assimp is built with assertions, and a malformed face (an OFF face
  // with no vertices, found by fuzzing) would otherwise abort the process inside triangulation.
  check_off_counts(file, bytes);  // any extension: assimp picks a reader by content too
  if (ext == ".obj") check_obj_lines(file);
  io::check_gltf_structure(file, bytes);
  const aiScene* scene = nullptr;
  try {
    scene = importer.ReadFile(file.string(), aiProcess_ValidateDataStructure | aiProcess_Triangulate |
                                                 aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices);
  } catch (const std::bad_alloc&) {
    throw Error(
        ErrorCode::parse,
        fmt::format("{}: reading it needs more memory than there is: is the file what it says it is?", file.string()));
  } catch (const std::exception& e) {
    throw Error(ErrorCode::parse, fmt::format("{}: cannot read the mesh: {}", file.string(), e.what()));
  }
  if (scene == nullptr)
    throw Error(ErrorCode::parse,
                fmt::format("{}: cannot read the mesh: {}", file.string(), importer.GetErrorString()));
  TriangleMesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(mesh.vertices.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      mesh.vertices.emplace_back(p.x, p.y, p.z);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines left by triangulation
      mesh.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  return mesh;
}

TriangleMesh load_mesh(const std::filesystem::path& file) {
  TriangleMesh mesh = load_mesh_as_read(file);
  check_mesh(mesh, file.string());
  return mesh;
}

TriangleMesh submesh(const TriangleMesh& mesh, std::span<const std::uint8_t> keep, std::vector<std::uint32_t>* kept) {
  TriangleMesh out;
  if (kept != nullptr) kept->clear();
  std::vector<std::uint32_t> index(mesh.vertices.size(), std::numeric_limits<std::uint32_t>::max());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (keep[t] == 0) continue;
    std::array<std::uint32_t, 3> tri{};
    for (std::size_t c = 0; c < 3; ++c) {
      std::uint32_t& slot = index[mesh.triangles[t][c]];
      if (slot == std::numeric_limits<std::uint32_t>::max()) {
        slot = static_cast<std::uint32_t>(out.vertices.size());
        out.vertices.push_back(mesh.vertices[mesh.triangles[t][c]]);
        if (kept != nullptr) kept->push_back(mesh.triangles[t][c]);
      }
      tri[c] = slot;
    }
    out.triangles.push_back(tri);
  }
  return out;
}

bool is_closed(const TriangleMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const auto& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t a = t[static_cast<std::size_t>(e)], b = t[static_cast<std::size_t>((e + 1) % 3)];
      edges[{std::min(a, b), std::max(a, b)}] += 1;
    }
  for (const auto& [edge, count] : edges)
    if (count != 2) return false;
  return !edges.empty();
}

void save_mesh(const std::filesystem::path& file, const TriangleMesh& mesh, std::span<const Eigen::Vector3d> normals) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const char* format = ext == ".obj"   ? "obj"
                       : ext == ".ply" ? "plyb"
                       : ext == ".stl" ? "stlb"
                       : ext == ".glb" ? "glb2"
                                       : nullptr;
  if (format == nullptr)
    throw Error(ErrorCode::invalid_argument,
                fmt::format("{}: unknown mesh format '{}' (expected .obj, .ply, .stl or .glb)", file.string(), ext));
  // A minimal assimp scene: one node, one material, one mesh. aiScene frees what it owns.
  aiScene scene;
  scene.mRootNode = new aiNode();
  scene.mRootNode->mNumMeshes = 1;
  scene.mRootNode->mMeshes = new unsigned[1]{0};
  scene.mNumMaterials = 1;
  scene.mMaterials = new aiMaterial* [1] { new aiMaterial() };
  scene.mNumMeshes = 1;
  scene.mMeshes = new aiMesh* [1] { new aiMesh() };
  aiMesh& m = *scene.mMeshes[0];
  m.mMaterialIndex = 0;
  m.mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  m.mNumVertices = static_cast<unsigned>(mesh.vertices.size());
  m.mVertices = new aiVector3D[mesh.vertices.size()];
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    m.mVertices[v] = aiVector3D(static_cast<float>(mesh.vertices[v].x()), static_cast<float>(mesh.vertices[v].y()),
                                static_cast<float>(mesh.vertices[v].z()));
  if (normals.size() == mesh.vertices.size()) {
    m.mNormals = new aiVector3D[normals.size()];
    for (std::size_t v = 0; v < normals.size(); ++v)
      m.mNormals[v] = aiVector3D(static_cast<float>(normals[v].x()), static_cast<float>(normals[v].y()),
                                 static_cast<float>(normals[v].z()));
  }
  m.mNumFaces = static_cast<unsigned>(mesh.triangles.size());
  m.mFaces = new aiFace[mesh.triangles.size()];
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    m.mFaces[t].mNumIndices = 3;
    m.mFaces[t].mIndices = new unsigned[3]{mesh.triangles[t][0], mesh.triangles[t][1], mesh.triangles[t][2]};
  }
  Assimp::Exporter exporter;
  if (exporter.Export(&scene, format, file.string()) != AI_SUCCESS)
    throw Error(ErrorCode::io, fmt::format("{}: cannot write the mesh: {}", file.string(), exporter.GetErrorString()));
}

double mesh_volume(std::span<const Eigen::Vector3d> vertices, std::span<const std::array<std::uint32_t, 3>> triangles) {
  double v = 0.0;
  for (const auto& t : triangles) v += vertices[t[0]].dot(vertices[t[1]].cross(vertices[t[2]]));
  return v / 6.0;
}

}  // namespace haustra
