// Shared helpers of the Python bindings: array conversion, the GIL-aware progress bridge, and
// one registration function per binding file (called from module.cpp). The bindings are thin
// adapters over the core: copy arrays in, call the core with the GIL released, copy results out.
#pragma once

#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>
#include <string>

namespace nhnet::python {

namespace py = pybind11;

/// A float64 array as the core's (N, 3) Points/Normals. Any array-like that numpy can cast to
/// float64 is accepted; anything not shaped (N, 3) raises nhnet.InvalidOptions (a ValueError)
/// naming `what` and the shape received.
Points to_points(const py::handle& array, const char* what);

/// An (N, 3) row-major double matrix as a new numpy float64 array (a copy).
py::array_t<double> to_numpy(const Points& m);

/// Bridges the core's progress callback to Python while the GIL is released: at most every
/// 50 ms it takes the GIL, checks for pending signals (Ctrl-C) and calls the user's
/// progress(fraction, stage) when given; a pending KeyboardInterrupt, an exception raised by the
/// callback, or a callback returning False cancels the core call. After the call, rethrow()
/// re-raises that Python exception in place of nhnet::Cancelled.
class ProgressBridge {
 public:
  explicit ProgressBridge(py::object user_callback);
  /// The callback to put into RunContext::progress.
  ProgressCallback callback();
  /// Call with the GIL held after catching nhnet::Cancelled: raises the stored Python error
  /// (KeyboardInterrupt / the callback's exception) if there is one; returns otherwise.
  void rethrow_if_python_error();

 private:
  bool on_progress(double fraction, const std::string& stage);
  py::object user_;
  std::chrono::steady_clock::time_point last_{};
  bool has_error_ = false;
  py::object type_, value_, trace_;
};

/// Runs `fn` with the GIL released, with a ProgressBridge passed in; maps a cancellation caused
/// by Ctrl-C or by the user's callback back to that Python exception.
template <class Fn>
auto run_released(const py::object& progress, Fn&& fn) {
  ProgressBridge bridge(progress);
  try {
    py::gil_scoped_release release;
    return fn(bridge.callback());
  } catch (const std::exception&) {
    bridge.rethrow_if_python_error();  // GIL held again here
    throw;
  }
}

void register_errors(py::module_& m);
void register_estimate(py::module_& m);
void register_io(py::module_& m);
void register_metrics(py::module_& m);
void register_descriptors(py::module_& m);

}  // namespace nhnet::python
