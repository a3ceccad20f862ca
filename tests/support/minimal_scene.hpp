#pragma once
// The smallest scene the scene tests build on: one segment "a" of 11 nodes, 0.5 m. A table the
// tests append after a blank line starts on line 10, its first key on line 11 (their expected
// messages name those lines).
namespace haustra::test {

inline constexpr const char* kMinimalScene = R"(
[scene]
name = "t"
[[segment]]
name = "a"
nodes = 11
[segment.rest]
length = 0.5
)";

}  // namespace haustra::test
