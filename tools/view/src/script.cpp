// Script files: parsed and checked whole before anything runs.
#include "script.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "haustra/error.hpp"

namespace haustra::view {
namespace {

struct Shape {
  std::size_t min_words, max_words;
  const char* usage;
};

const Shape* shape_of(const std::string& command) {
  static const std::pair<std::string, Shape> shapes[] = {
      {"wait", {1, 1, "wait FRAMES"}},
      {"press", {2, 2, "press X Y | press bead K"}},
      {"move", {2, 4, "move X Y [FRAMES] | move by DX DY [FRAMES]"}},
      {"release", {0, 0, "release"}},
      {"ctrl", {1, 1, "ctrl down|up"}},
      {"shift", {1, 1, "shift down|up"}},
      {"toggle", {1, 1, "toggle beads|cage|centreline|contacts|tissue"}},
      {"colour", {1, 1, "colour tissue|strain|penetration"}},
      {"knob", {2, 4, "knob NAME VALUE"}},
      {"pause", {0, 0, "pause"}},
      {"resume", {0, 0, "resume"}},
      {"step", {0, 0, "step"}},
      {"reset", {0, 0, "reset"}},
      {"save", {0, 0, "save"}},
      {"restore", {0, 0, "restore"}},
      {"screenshot", {1, 1, "screenshot FILE.png"}},
      {"key", {1, 1, "key F1|H|P|V|0|1|2|3|F|G|T|B|I|TAB|SPACE|RIGHT|ESC|CTRL+R|CTRL+O"}},
      {"open", {1, 1, "open FILE (a scene or a surface)"}},
      {"record", {1, 1, "record FILE.mp4 | record stop"}},
      {"zoom", {1, 1, "zoom STEPS (the wheel; > 0 closer)"}},
      {"select", {1, 2, "select KIND I | select none"}},
      {"edit", {4, 4, "edit KIND I FIELD VALUE"}},
      {"quit", {0, 0, "quit"}}};
  for (const auto& [name, shape] : shapes)
    if (name == command) return &shape;
  return nullptr;
}

double number(const std::string& word, const std::string& where, const char* what) {
  double x = 0.0;
  const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), x);
  if (ec != std::errc() || end != word.data() + word.size())
    throw Error(ErrorCode::parse, fmt::format("{}: '{}' is not {}", where, word, what));
  return x;
}

double index_word(const std::string& word, const std::string& where) {
  const double i = number(word, where, "an index (0 the first)");
  if (i < 0 || i != std::floor(i) || i > 1e9)
    throw Error(ErrorCode::parse, fmt::format("{}: '{}' is not an index (0 the first)", where, word));
  return i;
}

void check_word(const std::string& word, std::set<std::string> allowed, const std::string& where) {
  if (allowed.count(word) == 0)
    throw Error(ErrorCode::parse, fmt::format("{}: '{}' is not one of {}", where, word, fmt::join(allowed, ", ")));
}

}  // namespace

std::vector<ScriptLine> read_script(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw Error(ErrorCode::io, fmt::format("{}: cannot read the script", file.string()));
  std::vector<ScriptLine> lines;
  std::string text;
  for (int n = 1; std::getline(in, text); ++n) {
    if (const auto hash = text.find('#'); hash != std::string::npos) text.resize(hash);
    std::istringstream words(text);
    ScriptLine l;
    l.line = n;
    if (!(words >> l.command)) continue;
    for (std::string w; words >> w;) l.words.push_back(w);
    const std::string where = fmt::format("{} line {}", file.string(), n);
    const Shape* shape = shape_of(l.command);
    if (shape == nullptr)
      throw Error(ErrorCode::parse,
                  fmt::format("{}: unknown command '{}' (wait, press, move, release, ctrl, shift, toggle, "
                              "colour, knob, pause, resume, step, reset, save, restore, screenshot, key, open, "
                              "record, zoom, select, edit, quit)",
                              where, l.command));
    if (l.words.size() < shape->min_words || l.words.size() > shape->max_words)
      throw Error(ErrorCode::parse, fmt::format("{}: expected `{}`", where, shape->usage));
    if (l.command == "wait") l.frames = static_cast<int>(number(l.words[0], where, "a number of frames"));
    if (l.command == "press" && l.words[0] == "bead") {
      l.at_bead = true;
      l.x = number(l.words[1], where, "a bead index");
    } else if (l.command == "press" || l.command == "move") {
      std::size_t w = 0;
      l.relative = l.command == "move" && l.words[0] == "by";
      if (l.relative) ++w;
      if (l.words.size() < w + 2 || l.words.size() > w + 3)
        throw Error(ErrorCode::parse, fmt::format("{}: expected `{}`", where, shape->usage));
      l.x = number(l.words[w], where, "a window x (pixels)");
      l.y = number(l.words[w + 1], where, "a window y (pixels)");
      l.frames = l.words.size() > w + 2 ? static_cast<int>(number(l.words[w + 2], where, "a number of frames")) : 1;
    }
    if ((l.command == "wait" || l.command == "move") && l.frames < (l.command == "move" ? 1 : 0))
      throw Error(ErrorCode::parse, fmt::format("{}: the number of frames must be {}", where,
                                                l.command == "move" ? "at least 1" : "0 or more"));
    if (l.command == "zoom") l.x = number(l.words[0], where, "a number of wheel steps");
    if (l.command == "select") {
      check_word(l.words[0], {"none", "organ", "anchors", "instrument", "plane", "sphere", "capsule", "mesh"}, where);
      if ((l.words[0] == "none") != (l.words.size() == 1))
        throw Error(ErrorCode::parse, fmt::format("{}: expected `select KIND I | select none`", where));
      if (l.words.size() == 2) l.x = index_word(l.words[1], where);
    }
    if (l.command == "edit") {
      check_word(l.words[0], {"organ", "instrument", "contact"}, where);
      l.x = index_word(l.words[1], where);
      l.y = number(l.words[3], where, "a number");
    }
    if (l.command == "ctrl" || l.command == "shift") check_word(l.words[0], {"down", "up"}, where);
    if (l.command == "toggle") check_word(l.words[0], {"beads", "cage", "centreline", "contacts", "tissue"}, where);
    if (l.command == "colour") check_word(l.words[0], {"tissue", "strain", "penetration"}, where);
    if (l.command == "key")
      check_word(l.words[0], {"F1", "H", "P", "V", "0",   "1",     "2",     "3",   "F",      "G",
                              "T",  "K", "B", "I", "TAB", "SPACE", "RIGHT", "ESC", "CTRL+R", "CTRL+O"},
                 where);
    if (l.command == "knob" && l.words.size() > 2) {  // gravity takes three numbers
      l.words[1] = fmt::format("{}", fmt::join(l.words.begin() + 1, l.words.end(), " "));
      l.words.resize(2);
    }
    lines.push_back(std::move(l));
  }
  return lines;
}

}  // namespace haustra::view
