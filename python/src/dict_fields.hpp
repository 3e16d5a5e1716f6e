// Core structs as Python dicts and back, from one table of (key, member) pairs, so that a
// struct's keys are written once for both directions (tiles.cpp's TileDecisions, metrics.cpp's
// AngleStats). Include after <pybind11/stl.h> where a field is a std::vector.
#pragma once

#include <pybind11/pybind11.h>

#include <tuple>
#include <type_traits>

namespace nhnet::python {

namespace py = pybind11;

/// One field of a core struct and its dict key.
template <class Struct, class T>
struct Field {
  const char* key;
  T Struct::*member;
};

/// field("spacing", &TileDecisions::spacing).
template <class Struct, class T>
constexpr Field<Struct, T> field(const char* key, T Struct::*member) {
  return {key, member};
}

/// The fields of `s` named in `fields` (a std::tuple of Field) as a dict {key: value}.
template <class Struct, class... Fields>
py::dict fields_to_dict(const Struct& s, const std::tuple<Fields...>& fields) {
  py::dict d;
  std::apply([&](const auto&... f) { ((d[f.key] = s.*(f.member)), ...); }, fields);
  return d;
}

/// A Struct (default-constructed) with the fields named in `fields` taken from `d`; a missing
/// key raises KeyError, a value of the wrong type pybind11's cast_error.
template <class Struct, class... Fields>
Struct fields_from_dict(const py::dict& d, const std::tuple<Fields...>& fields) {
  Struct s;
  std::apply(
      [&](const auto&... f) {
        ((s.*(f.member) = d[f.key].template cast<std::decay_t<decltype(s.*(f.member))>>()), ...);
      },
      fields);
  return s;
}

}  // namespace nhnet::python
