// A glTF's JSON nesting and node hierarchy checked before assimp, whose JSON parser and node
// import recurse once per level (and would loop on a cycle).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"

namespace haustra::io {
namespace {

std::string lower_extension(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// A .glb's first chunk, its JSON (empty when the container is not what it should be: assimp says so).
std::string glb_json(const std::filesystem::path& file, std::uintmax_t bytes) {
  std::ifstream in(file, std::ios::binary);
  std::array<char, 20> head{};
  if (bytes < head.size() || !in.read(head.data(), head.size())) return {};
  std::uint32_t chunk_length = 0;
  std::memcpy(&chunk_length, head.data() + 12, sizeof chunk_length);
  if (std::memcmp(head.data(), "glTF", 4) != 0 || std::memcmp(head.data() + 16, "JSON", 4) != 0 ||
      chunk_length > bytes - head.size())
    return {};
  std::string json(chunk_length, '\0');
  if (!in.read(json.data(), static_cast<std::streamsize>(chunk_length))) return {};
  return json;
}

[[noreturn]] void refuse(const std::filesystem::path& file, const std::string& what) {
  throw Error(ErrorCode::invalid_argument, fmt::format("{}: {}: not read", file.string(), what));
}

// The nodes' children as lists, each node one parent at most.
std::vector<std::vector<std::size_t>> node_children(const std::filesystem::path& file, const nlohmann::json& nodes) {
  std::vector<std::vector<std::size_t>> children(nodes.size());
  std::vector<std::uint8_t> has_parent(nodes.size(), 0);
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    if (!nodes[n].is_object() || !nodes[n].contains("children") || !nodes[n]["children"].is_array()) continue;
    for (const nlohmann::json& c : nodes[n]["children"]) {
      if (!c.is_number_unsigned() || c.get<std::size_t>() >= nodes.size()) continue;  // assimp refuses these
      const auto child = c.get<std::size_t>();
      if (has_parent[child] != 0)
        refuse(file, fmt::format("glTF node {} has two parents (a glTF's nodes form trees)", child));
      has_parent[child] = 1;
      children[n].push_back(child);
    }
  }
  return children;
}

// Depth-first from every parentless node, with a stack of its own; a node never reached lies on a cycle.
void check_node_tree(const std::filesystem::path& file, const nlohmann::json& nodes) {
  const std::vector<std::vector<std::size_t>> children = node_children(file, nodes);
  std::vector<std::uint8_t> has_parent(nodes.size(), 0), reached(nodes.size(), 0);
  for (const auto& list : children)
    for (std::size_t c : list) has_parent[c] = 1;
  std::vector<std::pair<std::size_t, int>> stack;  // node, its depth
  for (std::size_t root = 0; root < nodes.size(); ++root) {
    if (has_parent[root] != 0) continue;
    stack.emplace_back(root, 1);
    while (!stack.empty()) {
      const auto [node, depth] = stack.back();
      stack.pop_back();
      reached[node] = 1;
      if (depth > kMaxNodeDepth)
        refuse(file, fmt::format("glTF node {} lies {} levels deep in the node hierarchy, more than {}", node, depth,
                                 kMaxNodeDepth));
      for (std::size_t c : children[node]) stack.emplace_back(c, depth + 1);
    }
  }
  const auto cycle = std::find(reached.begin(), reached.end(), 0);
  if (cycle != reached.end())
    refuse(file, fmt::format("glTF node {} is its own ancestor (the node hierarchy has a cycle)",
                             static_cast<std::size_t>(cycle - reached.begin())));
}

}  // namespace

void check_gltf_structure(const std::filesystem::path& file, std::uintmax_t bytes) {
  const std::string ext = lower_extension(file);
  std::string json;
  if (ext == ".gltf")
    json = read_bounded_file(file, "mesh file", bytes);
  else if (ext == ".glb")
    json = glb_json(file, bytes);
  else
    return;
  check_json_nesting(json, file.string());
  const nlohmann::json doc = nlohmann::json::parse(json, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("nodes") || !doc["nodes"].is_array()) return;
  check_node_tree(file, doc["nodes"]);
}

}  // namespace haustra::io
