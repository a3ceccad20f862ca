// A dict in the scene format's shape to TOML text, through toml++ (its writer quotes and escapes).
#include "descriptions.hpp"

#include <fmt/format.h>

#include <toml++/toml.h>
#include <sstream>

#include "haustra/error.hpp"

namespace py = pybind11;

namespace haustra::python {
namespace {

toml::table table_of(const py::dict& d, const std::string& path);

[[noreturn]] void refuse(const std::string& path, const py::handle& value) {
  throw FieldError(ErrorCode::invalid_argument, path,
                   fmt::format("expected a bool, int, float, str (or path), list or dict, got {}",
                               py::str(py::type::of(value).attr("__name__")).cast<std::string>()));
}

// Where a converted value goes: a table's key or the end of an array. Two fixed types, so the
// recursion through nested lists instantiates a finite set of templates.
struct IntoTable {
  toml::table& table;
  const std::string& key;
  template <class V>
  void operator()(V&& v) const {
    table.insert_or_assign(key, std::forward<V>(v));
  }
};
struct IntoArray {
  toml::array& array;
  template <class V>
  void operator()(V&& v) const {
    array.push_back(std::forward<V>(v));
  }
};

// One value under `path`; NumPy scalars and arrays arrive through their tolist().
template <class Into>
void insert_value(const py::handle& value, const std::string& path, const Into& insert) {
  if (py::hasattr(value, "tolist") && !py::isinstance<py::str>(value)) {
    insert_value(value.attr("tolist")(), path, insert);
  } else if (py::isinstance<py::bool_>(value)) {
    insert(value.cast<bool>());
  } else if (py::isinstance<py::int_>(value)) {
    insert(value.cast<std::int64_t>());
  } else if (py::isinstance<py::float_>(value)) {
    insert(value.cast<double>());
  } else if (py::isinstance<py::str>(value)) {
    insert(value.cast<std::string>());
  } else if (py::hasattr(value, "__fspath__")) {  // a pathlib.Path (any os.PathLike) as its text
    insert(py::module_::import("os").attr("fspath")(value).cast<std::string>());
  } else if (py::isinstance<py::dict>(value)) {
    insert(table_of(value.cast<py::dict>(), path));
  } else if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    toml::array array;
    std::size_t i = 0;
    for (const py::handle item : value) insert_value(item, fmt::format("{}[{}]", path, i++), IntoArray{array});
    insert(std::move(array));
  } else {
    refuse(path, value);
  }
}

toml::table table_of(const py::dict& d, const std::string& path) {
  toml::table table;
  for (const auto& [key, value] : d) {
    if (!py::isinstance<py::str>(key))
      throw Error(ErrorCode::invalid_argument,
                  fmt::format("{}: keys must be strings", path.empty() ? "description" : path));
    const std::string name = key.cast<std::string>();
    const std::string at = path.empty() ? name : path + "." + name;
    insert_value(value, at, IntoTable{table, name});
  }
  return table;
}

}  // namespace

std::string toml_text(const py::dict& description) {
  std::ostringstream out;
  out << table_of(description, "");
  return out.str();
}

std::vector<std::string> override_strings(const py::dict& overrides) {
  std::vector<std::string> out;
  for (const auto& [key, value] : overrides) {
    const std::string name = py::str(key).cast<std::string>();
    // The value alone, as TOML writes it: a one-entry table "v = <value>" with its key cut off.
    toml::table one;
    const std::string v = "v";
    insert_value(value, name, IntoTable{one, v});
    std::ostringstream text;
    text << one;
    const std::string line = text.str();
    out.push_back(name + "=" + line.substr(line.find('=') + 2));
  }
  return out;
}

}  // namespace haustra::python
