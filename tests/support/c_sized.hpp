#pragma once
// A C API struct as a C++ host fills one (structs carry their size since ABI 14): zeroed, its
// struct_size this header's. (`T x{sizeof(T)}` would leave -Wmissing-field-initializers to warn.)
template <class T>
T sized() {
  T t{};
  t.struct_size = sizeof(T);
  return t;
}
