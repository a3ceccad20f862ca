#pragma once
// Reading a scene file's TOML: the Reader that takes each value with its type, range and place
// checked, and names the file, line and field when one is wrong. Private to io/.
#include <fmt/format.h>

#include <toml++/toml.h>
#include <Eigen/Core>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "haustra/error.hpp"

namespace haustra::scene_io {

// Where something came from, for messages: "file:line:col", or "file (from --set)".
inline std::string where(const std::string& file, const toml::source_region& source) {
  if (source.begin.line > 0) return fmt::format("{}:{}:{}", file, source.begin.line, source.begin.column);
  return file + " (from --set)";
}

inline std::string where(const std::string& file, const toml::node* node) {
  return node != nullptr ? where(file, node->source()) : file + " (from --set)";
}

inline std::string describe_value(const toml::node& n) {
  std::ostringstream s;
  if (n.is_string()) return fmt::format("the string \"{}\"", *n.value<std::string>());
  if (n.is_table()) return "a table";
  if (n.is_array()) return "an array";
  n.visit([&](const auto& v) { s << v; });
  std::ostringstream type;
  type << n.type();
  return fmt::format("{} ({})", s.str(), type.str());
}

// Reads one scene document into a SceneDesc, checking every field.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  // code: parse for what the scene file itself gets wrong; a file it names keeps its own error's code.
  [[noreturn]] void fail(const toml::node* node, const std::string& path, const std::string& detail,
                         ErrorCode code = ErrorCode::parse) const {
    throw FieldError(code, path, detail, fmt::format("{}: {}: {}", where(file_, node), path, detail));
  }

  [[noreturn]] void fail_at(const toml::source_region& source, const std::string& path,
                            const std::string& detail) const {
    throw FieldError(ErrorCode::parse, path, detail, fmt::format("{}: {}: {}", where(file_, source), path, detail));
  }

  // Rejects keys the format once had and no longer has, saying so (an unknown key's message would
  // only list the keys there are).
  void refuse_removed(const toml::table& t, const std::string& path, std::initializer_list<std::string_view> removed,
                      std::string_view why) const {
    for (const std::string_view key : removed)
      if (const toml::node* n = t.get(key)) fail(n, path + "." + std::string(key), fmt::format("this key was {}", why));
  }

  // Rejects keys a table does not know, naming the ones it does.
  void check_keys(const toml::table& t, const std::string& path, std::initializer_list<std::string_view> known) const {
    for (const auto& [key, node] : t) {
      if (std::find(known.begin(), known.end(), key.str()) != known.end()) continue;
      std::string list;
      for (auto k : known) list += fmt::format("{}{}", list.empty() ? "" : ", ", k);
      const std::string full = path.empty() ? std::string(key.str()) : path + "." + std::string(key.str());
      fail_at(key.source().begin.line > 0 ? key.source() : node.source(), full,
              fmt::format("unknown key; expected one of: {}", list));
    }
  }

  const toml::table* table(const toml::table& parent, std::string_view key, const std::string& path) const {
    const toml::node* n = parent.get(key);
    if (n == nullptr) return nullptr;
    if (!n->is_table()) fail(n, path, fmt::format("expected a table, got {}", describe_value(*n)));
    return n->as_table();
  }

  double number(const toml::table& t, std::string_view key, const std::string& path, double fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (auto v = n->value<double>(); v && (n->is_floating_point() || n->is_integer())) {
      if (!std::isfinite(*v)) fail(n, path, "expected a finite number");
      return *v;
    }
    fail(n, path, fmt::format("expected a number, got {}", describe_value(*n)));
  }

  std::optional<double> optional_number(const toml::table& t, std::string_view key, const std::string& path) const {
    if (t.get(key) == nullptr) return std::nullopt;
    return number(t, key, path, 0.0);
  }

  int integer(const toml::table& t, std::string_view key, const std::string& path, int fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_integer()) fail(n, path, fmt::format("expected an integer, got {}", describe_value(*n)));
    const std::int64_t v = *n->value<std::int64_t>();
    if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      fail(n, path, fmt::format("{} is out of range", v));
    return static_cast<int>(v);
  }

  bool boolean(const toml::table& t, std::string_view key, const std::string& path, bool fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_boolean()) fail(n, path, fmt::format("expected true or false, got {}", describe_value(*n)));
    return *n->value<bool>();
  }

  std::string string(const toml::table& t, std::string_view key, const std::string& path,
                     const std::string& fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    if (!n->is_string()) fail(n, path, fmt::format("expected a string, got {}", describe_value(*n)));
    return *n->value<std::string>();
  }

  template <class Enum>
  Enum choice(const toml::table& t, std::string_view key, const std::string& path, Enum fallback,
              std::initializer_list<std::pair<std::string_view, Enum>> options) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const std::string v = string(t, key, path, "");
    std::string list;
    for (const auto& [name, value] : options) {
      if (name == v) return value;
      list += fmt::format("{}\"{}\"", list.empty() ? "" : ", ", name);
    }
    fail(n, path, fmt::format("expected one of {}, got \"{}\"", list, v));
  }

  // A fixed-length array of finite numbers: [x, y, z] or [a, b].
  template <int N>
  Eigen::Matrix<double, N, 1> numbers(const toml::table& t, std::string_view key, const std::string& path,
                                      const Eigen::Matrix<double, N, 1>& fallback) const {
    const toml::node* n = t.get(key);
    if (n == nullptr) return fallback;
    const char* shape = N == 3 ? "[x, y, z]" : "[a, b]";
    const toml::array* a = n->as_array();
    if (a == nullptr || a->size() != static_cast<std::size_t>(N))
      fail(n, path, fmt::format("expected {}, got {}", shape, describe_value(*n)));
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) {
      const toml::node& e = *a->get(static_cast<std::size_t>(i));
      if (!(e.is_floating_point() || e.is_integer())) fail(n, path, fmt::format("expected {} numbers", N));
      v[i] = *e.value<double>();
    }
    if (!v.allFinite()) fail(n, path, fmt::format("expected {} finite numbers", N));
    return v;
  }

  Eigen::Vector3d vec3(const toml::table& t, std::string_view key, const std::string& path,
                       const Eigen::Vector3d& fallback) const {
    return numbers<3>(t, key, path, fallback);
  }

  Eigen::Vector2d vec2(const toml::table& t, std::string_view key, const std::string& path,
                       const Eigen::Vector2d& fallback) const {
    return numbers<2>(t, key, path, fallback);
  }

  std::vector<int> integers(const toml::table& t, std::string_view key, const std::string& path) const {
    std::vector<int> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected an array of integers, got {}", describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      if (!e.is_integer())
        fail(n, fmt::format("{}[{}]", path, i), fmt::format("expected an integer, got {}", describe_value(e)));
      out.push_back(static_cast<int>(*e.value<std::int64_t>()));
    }
    return out;
  }

  // [[a, b], ...]: pairs of numbers.
  std::vector<std::pair<double, double>> pairs(const toml::table& t, std::string_view key,
                                               const std::string& path) const {
    std::vector<std::pair<double, double>> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected [[a, b], ...], got {}", describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::array* p = a->get(i)->as_array();
      if (p == nullptr || p->size() != 2 || !(p->get(0)->is_number()) || !(p->get(1)->is_number()))
        fail(a->get(i), fmt::format("{}[{}]", path, i), "expected [a, b] of two numbers");
      out.emplace_back(*p->get(0)->value<double>(), *p->get(1)->value<double>());
    }
    return out;
  }

  // [[x, y, z], ...]: points of finite numbers.
  std::vector<Eigen::Vector3d> points(const toml::table& t, std::string_view key, const std::string& path) const {
    std::vector<Eigen::Vector3d> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected [[x, y, z], ...], got {}", describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::array* p = a->get(i)->as_array();
      bool ok = p != nullptr && p->size() == 3;
      for (std::size_t j = 0; ok && j < 3; ++j)
        ok = p->get(j)->is_number() && std::isfinite(*p->get(j)->value<double>());
      if (!ok) fail(a->get(i), fmt::format("{}[{}]", path, i), "expected [x, y, z] of three finite numbers");
      out.emplace_back(*p->get(0)->value<double>(), *p->get(1)->value<double>(), *p->get(2)->value<double>());
    }
    return out;
  }

  // An array of tables (TOML [[name]]); absent is empty.
  std::vector<const toml::table*> tables(const toml::table& t, std::string_view key, const std::string& path) const {
    std::vector<const toml::table*> out;
    const toml::node* n = t.get(key);
    if (n == nullptr) return out;
    const toml::array* a = n->as_array();
    if (a == nullptr) fail(n, path, fmt::format("expected [[{}]] tables, got {}", key, describe_value(*n)));
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node* e = a->get(i);
      if (!e->is_table()) fail(e, fmt::format("{}[{}]", path, i), "expected a table");
      out.push_back(e->as_table());
    }
    return out;
  }

  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

}  // namespace haustra::scene_io
