// Bindings of the estimation pipeline (estimate.hpp): nhnet.estimate() returning the full
// result and nhnet.estimate_normals() returning only the (N, 3) normals.
#include "bindings.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/estimate.hpp"

#include <pybind11/stl.h>

#include <optional>

namespace nhnet::python {

namespace {

/// EstimateResult with its arrays converted once to numpy.
struct PyEstimateResult {
  py::array_t<double> normals;
  py::array_t<bool> valid;
  int64_t failed = 0;
  int64_t candidates = 0;
  double noise_ratio = 0;
  double spacing = 0;
  int k_used = 0;
  std::vector<int> scales_used;
  std::vector<std::string> warnings;
  int64_t flipped = 0;
};

PyEstimateResult estimate(const py::handle& points, const std::string& method, int k,
                          std::optional<std::vector<int>> scales, int threads, uint64_t seed,
                          const py::object& orient, const py::object& progress) {
  EstimateOptions opt;
  opt.method = method_from_string(method);
  opt.k = k;
  if (scales) opt.scales = *scales;
  opt.run.threads = threads;
  opt.seed = seed;
  const Points pts = to_points(points, "points");
  Normals reference;
  if (!orient.is_none()) {
    reference = to_points(orient, "orient (reference normals)");
    if (reference.rows() != pts.rows())
      throw InvalidOptions("orient must have one reference normal per point: got " +
                           std::to_string(reference.rows()) + " for " +
                           std::to_string(pts.rows()) + " points");
  }

  PyEstimateResult out;
  EstimateResult r = run_released(progress, [&](ProgressCallback cb) {
    opt.run.progress = std::move(cb);
    EstimateResult res = estimate_normals(pts, opt);
    if (reference.rows() > 0) out.flipped = orient_like(res.normals, reference);
    return res;
  });
  out.normals = to_numpy(r.normals);
  out.valid = py::array_t<bool>(py::ssize_t(r.valid.size()));
  bool* v = out.valid.mutable_data();
  for (size_t i = 0; i < r.valid.size(); ++i) v[i] = r.valid[i] != 0;
  out.failed = r.failed;
  out.candidates = r.candidates;
  out.noise_ratio = r.noise_ratio;
  out.spacing = r.spacing;
  out.k_used = r.k_used;
  out.scales_used = r.scales_used;
  out.warnings = r.warnings;
  return out;
}

const char* kArgsDoc = R"(
Parameters
----------
points : array_like, shape (N, 3)
    Point coordinates (converted to float64). Rows with a NaN or infinite coordinate are
    skipped: they get a NaN normal, are counted as failed and never influence their neighbours.
method : {'mfps', 'pca'}
    'mfps' (default): PCA for smooth points and multi-scale fitting patch selection near sharp
    features (paper Sec. 4). 'pca': plain PCA over the k nearest neighbours.
k : int
    PCA neighbourhood size (self included), 0 (default) = chosen from the noise level, else >= 3.
scales : sequence of int, optional
    MFPS patch sizes, e.g. [50, 100, 150] (the paper's); None (default) = chosen from the
    cloud's noise level.
threads : int
    Worker threads, 0 (default) = all cores.
seed : int
    Seed of MFPS's random plane samples; results are deterministic for a seed whatever the
    thread count (default 1, the same as nhnet-cli).
orient : array_like, shape (N, 3), optional
    Reference normals: each result normal is flipped to agree with its reference (what
    ``nhnet-cli estimate --orient keep`` does with the input's normals). None (default) leaves
    the normals unoriented (sign arbitrary).
progress : callable, optional
    ``progress(fraction: float, stage: str)`` called about every 50 ms; return False (or raise)
    to cancel: False raises nhnet.Cancelled, an exception is re-raised as it is.

The GIL is released while the core runs; Ctrl-C interrupts it (KeyboardInterrupt).

Raises
------
nhnet.InvalidOptions (ValueError)
    Bad parameter or array shape.
nhnet.UnprocessableInput (ValueError)
    Fewer than 3 finite points.
)";

}  // namespace

void register_estimate(py::module_& m) {
  py::class_<PyEstimateResult>(m, "EstimateResult",
                               "Everything nhnet.estimate() computed for one cloud.")
      .def_readonly("normals", &PyEstimateResult::normals,
                    "(N, 3) float64 unit normals; NaN rows for failed points.")
      .def_readonly("valid", &PyEstimateResult::valid,
                    "(N,) bool: True where a normal was computed.")
      .def_readonly("failed", &PyEstimateResult::failed, "Number of False entries in `valid`.")
      .def_readonly("candidates", &PyEstimateResult::candidates,
                    "Points classified as candidates near sharp features (MFPS only).")
      .def_readonly("noise_ratio", &PyEstimateResult::noise_ratio,
                    "Estimated noise level: residual bandwidth / average point spacing.")
      .def_readonly("spacing", &PyEstimateResult::spacing,
                    "Average distance to the nearest other point, input units.")
      .def_readonly("k_used", &PyEstimateResult::k_used, "PCA neighbourhood size used.")
      .def_readonly("scales_used", &PyEstimateResult::scales_used,
                    "MFPS patch sizes used (empty for PCA).")
      .def_readonly("warnings", &PyEstimateResult::warnings,
                    "Non-fatal notes (non-finite points skipped, clamped sizes, ...).")
      .def_readonly("flipped", &PyEstimateResult::flipped,
                    "Normals flipped to agree with `orient` (0 without it).")
      .def("__repr__", [](const PyEstimateResult& r) {
        return "<nhnet.EstimateResult points=" + std::to_string(r.normals.shape(0)) +
               " failed=" + std::to_string(r.failed) + " k_used=" + std::to_string(r.k_used) +
               " noise_ratio=" + std::to_string(r.noise_ratio) + ">";
      });

  const std::string estimate_doc =
      std::string("estimate(points, method='mfps', k=0, scales=None, threads=0, seed=1, "
                  "orient=None, progress=None) -> EstimateResult\n\n"
                  "Estimates unit normals and returns the full result (normals, valid mask, "
                  "failed count, noise ratio, sizes used, warnings).\n") +
      kArgsDoc;
  m.def("estimate", &estimate, estimate_doc.c_str(), py::arg("points"), py::kw_only(),
        py::arg("method") = "mfps", py::arg("k") = 0, py::arg("scales") = py::none(),
        py::arg("threads") = 0, py::arg("seed") = uint64_t(1), py::arg("orient") = py::none(),
        py::arg("progress") = py::none());

  const std::string normals_doc =
      std::string("estimate_normals(points, method='mfps', k=0, scales=None, threads=0, seed=1, "
                  "orient=None, progress=None) -> numpy.ndarray\n\n"
                  "Estimates unit normals: returns an (N, 3) float64 array, NaN rows for points "
                  "that failed. The core's warnings are issued as Python RuntimeWarnings; use "
                  "nhnet.estimate() for the valid mask, the noise ratio and the sizes used.\n") +
      kArgsDoc;
  m.def(
      "estimate_normals",
      [](const py::handle& points, const std::string& method, int k,
         std::optional<std::vector<int>> scales, int threads, uint64_t seed,
         const py::object& orient, const py::object& progress) {
        PyEstimateResult r = estimate(points, method, k, std::move(scales), threads, seed, orient,
                                      progress);
        for (const std::string& w : r.warnings)
          if (PyErr_WarnEx(PyExc_RuntimeWarning, ("nhnet: " + w).c_str(), 1) != 0)
            throw py::error_already_set();
        return r.normals;
      },
      normals_doc.c_str(), py::arg("points"), py::kw_only(), py::arg("method") = "mfps",
      py::arg("k") = 0, py::arg("scales") = py::none(), py::arg("threads") = 0,
      py::arg("seed") = uint64_t(1), py::arg("orient") = py::none(),
      py::arg("progress") = py::none());
}

}  // namespace nhnet::python
