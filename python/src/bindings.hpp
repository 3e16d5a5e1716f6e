// Shared helpers of the Python bindings: array conversion, the GIL-aware progress bridge, and
// one registration function per binding file (called from module.cpp). The bindings are thin
// adapters over the core: copy arrays in, call the core with the GIL released, copy results out.
#pragma once

#include "nhnet/io/cloud.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace nhnet::python {

namespace py = pybind11;

/// A float64 array as the core's (N, 3) Points/Normals. Any array-like that numpy can cast to
/// float64 is accepted; anything not shaped (N, 3) raises nhnet.InvalidOptions (a ValueError)
/// naming `what` and the shape received.
Points to_points(const py::handle& array, const char* what);

/// A row-major Eigen matrix (Points, Normals, IndexMatrix, a float descriptor matrix, ...) as a
/// new 2-D numpy array of the same scalar type, or an Eigen column vector as a 1-D array (copies).
template <class Matrix>
py::array_t<typename Matrix::Scalar> to_numpy(const Matrix& m) {
  using Scalar = typename Matrix::Scalar;
  static_assert(Matrix::IsRowMajor || Matrix::ColsAtCompileTime == 1, "row-major only");
  py::array_t<Scalar> a = Matrix::ColsAtCompileTime == 1
                              ? py::array_t<Scalar>(py::ssize_t(m.rows()))
                              : py::array_t<Scalar>({py::ssize_t(m.rows()), py::ssize_t(m.cols())});
  if (m.size() > 0) std::memcpy(a.mutable_data(), m.data(), sizeof(Scalar) * size_t(m.size()));
  return a;
}

/// A std::vector of numbers as a new 1-D numpy array of the same type (copies).
template <class T>
py::array_t<T> to_numpy(const std::vector<T>& v) {
  return py::array_t<T>(py::ssize_t(v.size()), v.data());
}

/// The core's per-point 0/1 flags (EstimateResult::valid) as a 1-D numpy bool array.
py::array_t<bool> to_numpy_mask(const std::vector<uint8_t>& flags);

/// Read-only property getter of one field of a core result held as `core` by a binding's
/// result class: def_property_readonly("failed",
/// core_field<PyEstimateResult>(&EstimateResult::failed)).
template <class Wrapper, class Core, class T>
auto core_field(T Core::*member) {
  return [member](const Wrapper& r) { return r.core.*member; };
}

/// Bridges the core's progress callback to Python while the GIL is released: at most every
/// 50 ms, and at every change of stage (so a caller can time the stages apart), it takes the GIL,
/// checks for pending signals (Ctrl-C) and calls the user's progress(fraction, stage) when given; a
/// pending KeyboardInterrupt, an exception raised by the callback, or a callback returning False
/// cancels the core call. After the call, rethrow() re-raises that Python exception in place of
/// nhnet::Cancelled.
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
  std::string last_stage_;  // the stage of the last report passed on
  bool has_error_ = false;
  bool stopped_ = false;  // once asked to stop, every later call says stop too
  py::object type_, value_, trace_;
};

/// Runs `fn` with the GIL released, with a ProgressBridge passed in; maps a cancellation caused
/// by Ctrl-C or by the user's callback back to that Python exception, also when the core ran to
/// its end after the request (a Ctrl-C is never dropped).
template <class Fn>
auto run_released(const py::object& progress, Fn&& fn) {
  ProgressBridge bridge(progress);
  try {
    auto result = [&] {
      py::gil_scoped_release release;
      return fn(bridge.callback());
    }();
    bridge.rethrow_if_python_error();  // GIL held again here
    return result;
  } catch (const std::exception&) {
    bridge.rethrow_if_python_error();
    throw;
  }
}

/// The orientation asked for by Python arguments. `orient`: None / 'none' / 'keep' / 'viewpoint'
/// / 'mst', or an (N, 3) array of reference normals (= 'keep' with them); `reference`: the
/// reference normals of 'keep' (when `orient` is a string); `viewpoint`: 3 numbers, 'viewpoint'
/// only (default the origin); `k`: 'mst' neighbours. Throws InvalidOptions for contradictions.
struct OrientRequest {
  OrientOptions options;
  Normals reference;
  std::string source;  ///< why this orientation (OrientPlan::source)
};

/// A cloud on the Python side (nhnet.Cloud): numpy arrays, extras as {name: 1-D array of the
/// file's type}, and what the file says about its sensor (io/cloud.hpp).
struct PyCloud {
  py::object points;
  py::object normals = py::none();
  py::dict extras;
  std::vector<Sensor> sensors;
  std::vector<int32_t> sensor_index;
  int64_t grid_width = 0, grid_height = 0;
  bool airborne = false;
};

/// The points of an (N, 3) array or of an nhnet.Cloud.
Points points_of(const py::handle& points);

/// A core Cloud with `pc`'s points, normals and sensor fields (no extras).
Cloud core_cloud(const PyCloud& pc);

/// `orient` "auto" made concrete: for an nhnet.Cloud by resolve_orientation (orient/auto.hpp;
/// keep takes the cloud's normals as the reference), for a bare array `array_mode`.
void resolve_request(OrientRequest& req, const py::handle& points, OrientMode array_mode);
OrientRequest orient_request(const py::object& orient, const py::object& reference,
                             const py::object& viewpoint, int k, Eigen::Index n);

void register_errors(py::module_& m);
void register_estimate(py::module_& m);
void register_io(py::module_& m);
void register_metrics(py::module_& m);
void register_orient(py::module_& m);
void register_denoise(py::module_& m);
void register_descriptors(py::module_& m);
void register_tiles(py::module_& m);

}  // namespace nhnet::python
