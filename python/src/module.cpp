// The extension module nhnet._nhnet; the package nhnet (python/nhnet/__init__.py) re-exports it.
// Each area of the core has its own binding file with a register_<area>() function.
#include "bindings.hpp"

#include "nhnet/version.hpp"

PYBIND11_MODULE(_nhnet, m) {
  m.doc() = "nhnet core bindings (use the package `nhnet`, which re-exports everything here).";
  m.attr("__version__") = nhnet::version();
  nhnet::python::register_errors(m);
  nhnet::python::register_estimate(m);
  nhnet::python::register_io(m);
  nhnet::python::register_metrics(m);
  nhnet::python::register_orient(m);
  nhnet::python::register_denoise(m);
  nhnet::python::register_descriptors(m);
  nhnet::python::register_tiles(m);
}
