#pragma once
// Untrusted files read within bounds (decision 0098): regular files only, a size limit, and the
// nesting depth of TOML and JSON text measured before a recursive parser or destructor sees it.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace haustra::io {

// The limits, each named in the message of the file that passes it (docs/guide.md, Reliability).
inline constexpr std::uintmax_t kMaxSceneBytes = std::uintmax_t{16} << 20;       // a scene is a few KB
inline constexpr std::uintmax_t kMaxCentrelineBytes = std::uintmax_t{64} << 20;  // ~1M points
inline constexpr std::uintmax_t kMaxCheckpointBytes = std::uintmax_t{1} << 30;
// Levels of tables, arrays and objects a scene, a centreline or a glTF's JSON may nest (a scene
// uses 5, a centreline 3, a glTF about 6); the parsers and destructors recurse once per level.
inline constexpr int kMaxNesting = 64;
// Levels of a glTF's node hierarchy (assimp builds and flattens it recursively).
inline constexpr int kMaxNodeDepth = 256;

// The size of `file` if it is a regular file of at most max_bytes; else Error{io} (not there, not
// a regular file: a folder, a FIFO, a device) or Error{invalid_argument} (too large), naming `what`
// ("scene file") and the limit. Never opens the file, so a FIFO cannot block it.
std::uintmax_t regular_file_size(const std::filesystem::path& file, std::string_view what, std::uintmax_t max_bytes);

// The whole content of a regular file of at most max_bytes, refused as above; opened without
// blocking and read no further than the limit, even if the file grows meanwhile.
std::string read_bounded_file(const std::filesystem::path& file, std::string_view what, std::uintmax_t max_bytes);

// Where text first nests deeper than a limit: 1-based line and column, and the depth reached there.
struct Nesting {
  bool within = true;
  int depth = 0;  // the deepest level seen (the first beyond the limit when !within)
  std::size_t line = 1, column = 1;
};

// Tables, arrays and inline tables of TOML text, counting every part of a dotted key or table
// header as a level (and each header part twice: it may be an array of tables). Strings and
// comments are skipped; malformed text is measured as far as it goes (the parser refuses it later).
[[nodiscard]] Nesting toml_nesting(std::string_view text, int limit = kMaxNesting);
// Arrays and objects of JSON text; strings skipped.
[[nodiscard]] Nesting json_nesting(std::string_view text, int limit = kMaxNesting);

// Error{invalid_argument} "<where>:<line>:<column>: the <format> nests more than <limit> levels
// deep ..." when the text passes the limit.
void check_toml_nesting(std::string_view text, const std::string& where, int limit = kMaxNesting);
void check_json_nesting(std::string_view text, const std::string& where, int limit = kMaxNesting);

// A glTF's (.gltf text or .glb's JSON chunk) structure, before assimp reads it: its JSON within
// kMaxNesting, its nodes a forest (one parent at most, no cycle) at most kMaxNodeDepth deep.
// Error{invalid_argument} naming the file and the node otherwise; JSON that does not parse is left to
// assimp to refuse. Other formats: nothing to check.
void check_gltf_structure(const std::filesystem::path& file, std::uintmax_t bytes);

}  // namespace haustra::io
