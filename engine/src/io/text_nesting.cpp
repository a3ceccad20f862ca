// How deep TOML and JSON text nests, measured in one pass with an explicit stack (never by
// recursion: the text is untrusted), so a parser that recurses is only given text it can hold.
#include <fmt/format.h>

#include <vector>

#include "haustra/error.hpp"
#include "io/bounded_input.hpp"

namespace haustra::io {
namespace {

// Characters with their line and column, and the deepest level reached.
class Cursor {
 public:
  Cursor(std::string_view text, int limit) : text_(text), limit_(limit) {}

  [[nodiscard]] bool done() const { return at_ >= text_.size() || !result_.within; }
  [[nodiscard]] char peek(std::size_t ahead = 0) const {
    return at_ + ahead < text_.size() ? text_[at_ + ahead] : '\0';
  }
  void advance() {
    if (text_[at_] == '\n') {
      ++line_;
      line_start_ = at_ + 1;
    }
    ++at_;
  }
  struct Place {
    std::size_t line, column;
  };
  [[nodiscard]] Place place() const { return {line_, at_ - line_start_ + 1}; }
  // A node `depth` levels deep begins at `where`.
  void reach(int depth, Place where) {
    if (depth <= result_.depth) return;
    result_.depth = depth;
    if (depth > limit_) result_ = {false, depth, where.line, where.column};
  }
  [[nodiscard]] const Nesting& result() const { return result_; }

  // A quoted string from its opening quote: '…', "…" (with escapes), or either tripled.
  void skip_string() {
    const char q = peek();
    const bool escapes = q == '"';
    const bool triple = peek(1) == q && peek(2) == q;
    for (int i = 0; i < (triple ? 3 : 1); ++i) advance();
    while (at_ < text_.size()) {
      const char c = peek();
      if (escapes && c == '\\' && at_ + 1 < text_.size()) {
        advance();
        advance();
        continue;
      }
      if (!triple && c == '\n') return;  // unterminated: the parser will say so
      if (c == q && (!triple || (peek(1) == q && peek(2) == q))) {
        for (int i = 0; i < (triple ? 3 : 1); ++i) advance();
        return;
      }
      advance();
    }
  }

 private:
  std::string_view text_;
  int limit_;
  std::size_t at_ = 0, line_ = 1, line_start_ = 0;
  Nesting result_;
};

// TOML: statements (table headers and key = value) and the values' arrays and inline tables.
class TomlScan {
 public:
  TomlScan(std::string_view text, int limit) : c_(text, limit) {}

  Nesting run() {
    int base = 0;  // the depth of the table the statements go into
    while (!c_.done()) {
      skip_blank(true);
      if (c_.done()) break;
      if (c_.peek() == '[') {
        const Cursor::Place where = c_.place();
        c_.advance();
        base = 2 * key_parts(']');  // each part may be an array of tables and its element
        c_.reach(base, where);
        skip_line();
        continue;
      }
      const Cursor::Place where = c_.place();
      const int depth = base + key_parts('=');
      c_.reach(depth, where);
      if (c_.peek() == '=') c_.advance();
      value(depth);
      skip_line();
    }
    return c_.result();
  }

 private:
  struct Open {
    bool array;
    int depth;  // of the array or inline table itself
  };

  void skip_blank(bool newlines) {
    while (!c_.done()) {
      const char ch = c_.peek();
      if (ch == '#') {
        while (!c_.done() && c_.peek() != '\n') c_.advance();
      } else if (ch == ' ' || ch == '\t' || ch == '\r' || (newlines && ch == '\n')) {
        c_.advance();
      } else {
        return;
      }
    }
  }

  void skip_line() {
    while (!c_.done() && c_.peek() != '\n') {
      if (c_.peek() == '"' || c_.peek() == '\'')
        c_.skip_string();
      else
        c_.advance();
    }
  }

  // A key's dotted parts up to `stop` (not consumed), quoted parts skipped whole.
  int key_parts(char stop) {
    int parts = 1;
    while (!c_.done()) {
      const char ch = c_.peek();
      if (ch == stop || ch == '\n' || ch == '}' || ch == ',' || (stop == '=' && ch == ']')) break;
      if (ch == '"' || ch == '\'') {
        c_.skip_string();
        continue;
      }
      if (ch == '.') ++parts;
      c_.advance();
    }
    return parts;
  }

  // After '{' or an inline table's ',': a key, '=', and the depth of the value that follows.
  int inline_key(int table_depth) {
    skip_blank(true);
    const Cursor::Place where = c_.place();
    const int depth = table_depth + key_parts('=');
    c_.reach(depth, where);
    if (c_.peek() == '=') c_.advance();
    return depth;
  }

  // One value `depth` levels deep, with everything nested in it, iteratively.
  void value(int depth) {
    std::vector<Open> open;
    int d = depth;
    bool want_value = true;
    while (!c_.done()) {
      if (want_value) {
        skip_blank(!open.empty());
        const Cursor::Place where = c_.place();
        const char ch = c_.peek();
        if (ch == '[') {
          c_.advance();
          open.push_back({true, d});
          c_.reach(d + 1, where);
          d += 1;
          skip_blank(true);
          want_value = c_.peek() != ']';
          continue;
        }
        if (ch == '{') {
          c_.advance();
          open.push_back({false, d});
          skip_blank(true);
          if (c_.peek() != '}') d = inline_key(d);
          want_value = c_.peek() != '}' && !c_.done();
          continue;
        }
        if (ch == '"' || ch == '\'') {
          c_.skip_string();
        } else {
          bool moved = false;
          while (!c_.done() && c_.peek() != ',' && c_.peek() != ']' && c_.peek() != '}' && c_.peek() != '\n' &&
                 c_.peek() != '#') {
            c_.advance();
            moved = true;
          }
          if (!moved && open.empty()) return;
        }
        want_value = false;
      }
      if (open.empty()) return;
      skip_blank(true);
      if (c_.done()) return;
      const char ch = c_.peek();
      c_.advance();
      if (ch == ',') {
        if (open.back().array) {
          d = open.back().depth + 1;
          skip_blank(true);
          want_value = c_.peek() != ']';
        } else {
          d = inline_key(open.back().depth);
          want_value = true;
        }
      } else if ((ch == ']' && open.back().array) || (ch == '}' && !open.back().array)) {
        open.pop_back();
      }  // anything else is malformed: passed over, the parser refuses it later
    }
  }

  Cursor c_;
};

}  // namespace

Nesting toml_nesting(std::string_view text, int limit) { return TomlScan(text, limit).run(); }

Nesting json_nesting(std::string_view text, int limit) {
  Cursor c(text, limit);
  int depth = 0;
  while (!c.done()) {
    const char ch = c.peek();
    if (ch == '"') {
      c.skip_string();
      continue;
    }
    if (ch == '[' || ch == '{') c.reach(++depth, c.place());
    if ((ch == ']' || ch == '}') && depth > 0) --depth;
    c.advance();
  }
  return c.result();
}

void check_toml_nesting(std::string_view text, const std::string& where, int limit) {
  const Nesting n = toml_nesting(text, limit);
  if (n.within) return;
  throw Error(ErrorCode::invalid_argument,
              fmt::format("{}:{}:{}: the TOML nests more than {} levels deep here (tables, dotted keys, arrays and "
                          "inline tables together; a scene needs 5): not read",
                          where, n.line, n.column, limit));
}

void check_json_nesting(std::string_view text, const std::string& where, int limit) {
  const Nesting n = json_nesting(text, limit);
  if (n.within) return;
  throw Error(ErrorCode::invalid_argument,
              fmt::format("{}:{}:{}: the JSON nests more than {} levels of arrays and objects here (a centreline "
                          "needs 3, a glTF about 6): not read",
                          where, n.line, n.column, limit));
}

}  // namespace haustra::io
