// `--set key=value` on a scene's TOML before it is read: the key's path ("segment[1].nodes") walked
// and the value put there, arrays of tables indexed.
#include "io/scene_overrides.hpp"

#include <fmt/format.h>

#include <span>
#include <string>
#include <vector>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"

namespace haustra::scene_io {
namespace {

// "segment[1].nodes" → {"segment", 1}, {"nodes", none}
struct PathPart {
  std::string key;
  std::optional<std::size_t> index;
};

std::vector<PathPart> split_path(const std::string& path, const std::string& file) {
  std::vector<PathPart> parts;
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t dot = path.find('.', start);
    std::string piece = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    PathPart part;
    if (const std::size_t lb = piece.find('['); lb != std::string::npos) {
      const std::size_t rb = piece.find(']', lb);
      if (rb == std::string::npos || rb + 1 != piece.size())
        throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: expected key[index]", file, path));
      try {
        part.index = static_cast<std::size_t>(std::stoul(piece.substr(lb + 1, rb - lb - 1)));
      } catch (const std::exception&) {
        throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: the index must be a number", file, path));
      }
      piece = piece.substr(0, lb);
    }
    if (piece.empty()) throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: empty key", file, path));
    part.key = piece;
    parts.push_back(part);
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return parts;
}

void set_path(toml::table& table, std::span<const PathPart> parts, const toml::node& value, const std::string& what) {
  const PathPart& p = parts.front();
  if (parts.size() == 1) {
    if (p.index) throw Error(ErrorCode::invalid_argument, what + ": cannot index the last key");
    const toml::node* existing = table.get(p.key);
    if (existing != nullptr && (existing->is_table() || existing->is_array_of_tables()))
      throw Error(ErrorCode::invalid_argument, what + ": that key is a table, not a value");
    table.insert_or_assign(p.key, value);
    return;
  }
  toml::node* n = table.get(p.key);
  if (n == nullptr) {
    if (p.index) throw Error(ErrorCode::invalid_argument, fmt::format("{}: there is no {}[{}]", what, p.key, *p.index));
    table.insert(p.key, toml::table{});
    n = table.get(p.key);
  }
  if (toml::array* a = n->as_array(); a != nullptr && a->is_array_of_tables()) {
    if (p.index) {
      if (*p.index >= a->size())
        throw Error(ErrorCode::invalid_argument,
                    fmt::format("{}: {}[{}] does not exist (there are {})", what, p.key, *p.index, a->size()));
      set_path(*a->get(*p.index)->as_table(), parts.subspan(1), value, what);
    } else {
      for (auto& e : *a) set_path(*e.as_table(), parts.subspan(1), value, what);
    }
    return;
  }
  if (!n->is_table() || p.index)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: {} is not a table", what, p.key));
  set_path(*n->as_table(), parts.subspan(1), value, what);
}

}  // namespace

void apply_override(toml::table& root, const std::string& assignment, const std::string& file) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set {}: expected key=value", file, assignment));
  const std::string key = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  const std::vector<PathPart> path = split_path(key, file);
  if (path.size() > static_cast<std::size_t>(io::kMaxNesting))  // set_path walks it recursively
    throw Error(ErrorCode::invalid_argument, fmt::format("{}: --set: the key has {} parts, more than the {} a scene "
                                                         "nests",
                                                         file, path.size(), io::kMaxNesting));
  io::check_toml_nesting("v = " + text, fmt::format("{} (--set {})", file, key));
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + text);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", text}};  // a bare word is a string
  }
  set_path(root, path, *parsed.get("v"), fmt::format("{}: --set {}", file, assignment));
}

}  // namespace haustra::scene_io
