#pragma once
// A figure a test measures and asserts, recorded for docs/results.md (`make results`): checked
// against its bound here, and, when HAUSTRA_RESULTS names a file, appended to it as one JSON line
// (figure, value, bound, unit). One source for the number the docs show and the test asserts.
#include <doctest/doctest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace haustra::test {

inline void measured(const std::string& figure, double value, double bound, const std::string& unit = "") {
  CHECK_MESSAGE(value <= bound, figure << ": " << value << " " << unit << " is above its bound " << bound);
  if (const char* file = std::getenv("HAUSTRA_RESULTS")) {
    std::ofstream out(file, std::ios::app);
    out << nlohmann::json{{"figure", figure}, {"value", value}, {"bound", bound}, {"unit", unit}}.dump() << '\n';
  }
}

}  // namespace haustra::test
