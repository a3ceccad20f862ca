// Bounded input (decision 0098): the nesting scanners measure TOML and JSON as their parsers would
// nest it (strings, comments and quoted keys skipped), and files are read only when regular and small.
#include <doctest/doctest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"

namespace haustra::io {
namespace {

const std::filesystem::path kScenes = std::filesystem::path(HAUSTRA_SOURCE_DIR) / "scenes";

TEST_CASE("TOML nesting: tables, dotted keys, arrays and inline tables counted, strings and comments not") {
  CHECK(toml_nesting("").depth == 0);
  CHECK(toml_nesting("a = 1\n").depth == 1);
  CHECK(toml_nesting("a.b.c = 1\n").depth == 3);
  CHECK(toml_nesting("[segment.mesh.procedural]\nvertices = 1\n").depth == 7);  // each header part counts twice
  CHECK(toml_nesting("[[segment]]\n[[segment.attachment]]\nnode = 1\n").depth == 5);
  CHECK(toml_nesting("x = [[1, 2], [3]]\n").depth == 3);
  CHECK(toml_nesting("x = {a.b = {c = [1]}}\n").depth == 5);
  CHECK(toml_nesting("x = [\n  [1], # a comment [[[[\n  [2],\n]\n").depth == 3);
  CHECK(toml_nesting("s = \"[[[[{{\"\n").depth == 1);
  CHECK(toml_nesting("s = \"\\\"[[[[\"\n").depth == 1);
  CHECK(toml_nesting("s = '''\n[[[[\n'''\nt = \"\"\"\n{{{{\n\"\"\"\n").depth == 1);
  CHECK(toml_nesting("\"a.b.c\" = 1\n'd.e' = 2\n").depth == 1);
  CHECK(toml_nesting("# [a.b.c.d]\n").depth == 0);
  CHECK(toml_nesting("[\"x.y\".z]\n").depth == 4);
}

TEST_CASE("TOML nesting: the first place past the limit, with its line and column") {
  std::string parts = "a";
  for (int i = 0; i < 9; ++i) parts += ".a";
  const Nesting header = toml_nesting("a = 1\n[" + parts + "]\n", 4);
  CHECK_FALSE(header.within);
  CHECK(header.line == 2);
  CHECK(header.column == 1);
  const Nesting array = toml_nesting("x = " + std::string(300, '[') + std::string(300, ']') + "\n");
  CHECK_FALSE(array.within);
  CHECK(array.line == 1);
  CHECK(array.column == 68);  // the 64th '[' puts its elements 65 levels deep
  const Nesting inline_tables = toml_nesting("x = " + [] {
    std::string s;
    for (int i = 0; i < 100; ++i) s += "{a=";
    return s + "1" + std::string(100, '}');
  }());
  CHECK_FALSE(inline_tables.within);
  CHECK(toml_nesting("x = " + std::string(63, '[') + std::string(63, ']') + "\n").within);
  CHECK_FALSE(toml_nesting("x = " + std::string(64, '[') + std::string(64, ']') + "\n").within);
}

TEST_CASE("TOML nesting: malformed text is measured as far as it goes, and every scene is well within") {
  CHECK(toml_nesting("[a.b\nc = ]]]] }}} ,,,\n x = [1, 2\n").within);  // ends early, no loop
  std::string unclosed = "x = [";
  for (int i = 0; i < 100; ++i) unclosed += "{a=";
  CHECK_FALSE(toml_nesting(unclosed).within);  // inline tables never closed still count
  for (const auto& entry : std::filesystem::directory_iterator(kScenes)) {
    if (entry.path().extension() != ".toml") continue;
    std::ifstream in(entry.path());
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const Nesting n = toml_nesting(text);
    INFO(entry.path().filename().string() << ": " << n.depth);
    CHECK(n.within);
    CHECK(n.depth <= 12);
  }
}

TEST_CASE("JSON nesting: arrays and objects counted, strings skipped") {
  CHECK(json_nesting("{\"units\": \"m\", \"points\": [[0, 0, 0], [1, 0, 0]]}").depth == 3);
  CHECK(json_nesting("\"[[[[{{{{\"").depth == 0);
  CHECK(json_nesting("{\"s\": \"\\\"[[[[\"}").depth == 1);
  const Nesting deep = json_nesting("{\"points\": [\n" + std::string(100, '[') + std::string(100, ']') + "]}");
  CHECK_FALSE(deep.within);
  CHECK(deep.line == 2);
  CHECK(deep.column == 63);  // depth 65 at the 63rd '[' of line 2
}

// A folder of this process's own for the file cases.
struct Folder {
  std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("haustra-bounded-" + std::to_string(::getpid()));
  Folder() { std::filesystem::create_directories(dir); }
  ~Folder() { std::filesystem::remove_all(dir); }
  Folder(const Folder&) = delete;
  Folder& operator=(const Folder&) = delete;
};

TEST_CASE("files: only regular ones, within their limit, read whole") {
  const Folder f;
  const std::filesystem::path text = f.dir / "a.toml";
  std::ofstream(text) << "a = 1\n";
  CHECK(read_bounded_file(text, "scene file", 100) == "a = 1\n");
  CHECK(regular_file_size(text, "scene file", 100) == 6);
  CHECK_THROWS_WITH_AS(read_bounded_file(text, "scene file", 5),
                       doctest::Contains("a.toml: 6 bytes, more than the 5 bytes a scene file may have"), Error);
  const std::filesystem::path fifo = f.dir / "pipe.toml";
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK_THROWS_WITH_AS(read_bounded_file(fifo, "scene file", 100),
                       doctest::Contains("pipe.toml: a FIFO (named pipe), not a scene file"), Error);
  CHECK_THROWS_WITH_AS(read_bounded_file(f.dir, "scene file", 100), doctest::Contains("a folder, not a scene file"),
                       Error);
  CHECK_THROWS_WITH_AS(read_bounded_file("/dev/zero", "centreline file", 100),
                       doctest::Contains("/dev/zero: a character device, not a centreline file"), Error);
  CHECK_THROWS_WITH_AS(read_bounded_file(f.dir / "missing.toml", "scene file", 100),
                       doctest::Contains("missing.toml: cannot open the scene file (No such file or directory)"),
                       Error);
  try {
    (void)read_bounded_file(fifo, "scene file", 100);
  } catch (const Error& e) {
    CHECK(e.code() == ErrorCode::io);
  }
}

}  // namespace
}  // namespace haustra::io
