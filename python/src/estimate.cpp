// Bindings of the estimation pipeline (estimate.hpp): nhnet.estimate() returning the full
// result and nhnet.estimate_normals() returning only the (N, 3) normals.
#include "bindings.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/learned/confidence.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/estimate_oriented.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <cmath>
#include <optional>
#include <string>
#include <tuple>

namespace nhnet::python {

namespace {

/// EstimateResult with its arrays converted once to numpy (the core's copies are dropped).
struct PyEstimateResult {
  EstimateResult core;
  py::array_t<double> normals;
  py::array_t<bool> valid;
  py::array_t<double> curvature;
  py::object confidence = py::none();      ///< (N,) with confidence=True, else None
  OrientResult orient;                     ///< what orient= did (zeros without it)
  std::string orient_mode, orient_source;  ///< the orientation applied and why
};

/// cell_means=: True (the core's ratio), False (0), the noise ratio from which (a number > 0) or
/// nhnet-cli's text ("auto", "off", "1.2").
double cell_means_ratio(const py::object& value) {
  std::string text;
  if (py::isinstance<py::bool_>(value))
    text = value.cast<bool>() ? "auto" : "off";
  else if (py::isinstance<py::str>(value) || py::isinstance<py::float_>(value) ||
           py::isinstance<py::int_>(value))
    text = std::string(py::str(value));
  try {
    return cell_means_from_string(text);
  } catch (const InvalidOptions& e) {
    throw InvalidOptions(std::string("cell_means ") + e.what() + " (or True / False)");
  }
}

PyEstimateResult estimate(const py::handle& points, const std::optional<std::string>& method, int k,
                          std::optional<std::vector<int>> scales, int threads, uint64_t seed,
                          const py::object& orient, const py::object& viewpoint,
                          const py::object& progress, const std::string& refine,
                          const std::optional<std::string>& model, const std::string& device,
                          const std::string& precision, bool learned_fit,
                          const py::object& cell_means, bool confidence) {
  EstimateOptions opt;
  opt.confidence = confidence;
  opt.cell_means.noise_ratio = cell_means_ratio(cell_means);
  opt.method = method ? method_from_string(*method) : default_method();
  opt.model.refine = refine_from_string(refine);
  if (model) opt.model.path = *model;
  opt.model.device = device;
  opt.model.precision = precision;
  opt.model.learned_fit = learned_fit;
  opt.k = k;
  if (scales) opt.mfps.scales = *scales;
  opt.mfps.seed = seed;
  const Points pts = points_of(points);
  OrientRequest req = orient_request(orient, py::none(), viewpoint, OrientOptions().k, pts.rows());
  resolve_request(req, points, OrientMode::None);

  PyEstimateResult out;
  out.orient_mode = to_string(req.options.mode);
  out.orient_source = req.source;
  out.core = run_released(progress, [&](ProgressCallback cb) {
    OrientedResult both =
        estimate_oriented(pts, opt, req.options, RunContext{threads, std::move(cb)}, req.reference);
    out.orient = both.orient;
    return std::move(both.estimate);
  });
  EstimateResult& r = out.core;
  out.normals = to_numpy(r.normals);
  out.valid = to_numpy_mask(r.valid);
  out.curvature = to_numpy(r.curvature);
  if (confidence) out.confidence = to_numpy(r.confidence);
  r.normals.resize(0, 3);
  r.valid.clear();
  r.curvature.resize(0);
  r.confidence.resize(0);
  return out;
}

const char* kArgsDoc = R"(
Parameters
----------
points : array_like, shape (N, 3), or nhnet.Cloud
    Point coordinates (converted to float64), or a cloud from nhnet.read() (its points; its
    normals and sensor decide orient='auto'). Rows with a NaN or infinite coordinate are
    skipped: they get a NaN normal, are counted as failed and never influence their neighbours.
method : {None, 'nhnet', 'mfps', 'pca'}
    None (default): the core's default_method(), as nhnet-cli: 'nhnet' when this build has
    libtorch and the shipped model is installed, else 'mfps'. 'nhnet': MFPS refined by the
    trained NH-Net. 'mfps': PCA for smooth points and multi-scale fitting patch selection near sharp
    features (paper Sec. 4), candidates then blended towards their PCA normal where the
    selection is likely wrong (docs/design/paper.md#the-geometry-stage-as-implemented, step 4). 'pca': plain PCA over the k nearest neighbours.
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
orient : 'auto', None, 'mst', 'viewpoint', 'up' or array_like (N, 3)
    'auto' (default): for an nhnet.Cloud, what its file says, as nhnet-cli (its normals' signs,
    else towards its sensor: PCD VIEWPOINT, PLY camera, an organized grid's origin; else 'up'
    for airborne scans; else 'mst'); for a bare array nothing is known and the normals stay
    unoriented (see `orient_source`). None: unoriented normals (sign arbitrary). 'up': +z where
    the surface is not near vertical. 'mst': consistent signs propagated
    over the k-NN graph (see nhnet.orient). 'viewpoint': every normal turned towards
    `viewpoint`. An (N, 3) array: reference normals each result normal is flipped to agree
    with (what ``nhnet-cli estimate --orient keep`` does with the input's normals).
viewpoint : sequence of 3 numbers, optional
    Sensor position for orient='viewpoint' (default the origin).
progress : callable, optional
    ``progress(fraction: float, stage: str)`` called about every 50 ms; return False (or raise)
    to cancel: False raises nhnet.Cancelled, an exception is re-raised as it is.
refine : {'auto', 'all', 'moved'}
    NH-Net only (nhnet-cli --refine): 'all' runs the network on every point; 'moved' only where
    MFPS moved the PCA normal (near features), the geometric candidates (jet, half-scale PCA,
    radial) elsewhere: much less network time, PCA's accuracy on broad noisy smooth surfaces;
    'auto' (default): 'all' on a noisy cloud, 'moved' on a clean one (noise ratio below 0.02),
    where the network adds little away from features.
model : str, optional
    NH-Net only (nhnet-cli --model): a model file from nhnet-train / nhnet-export; None
    (default): $NHNET_MODEL if set, else the shipped model.
device : {'auto', 'cpu', 'cuda'}
    NH-Net only (nhnet-cli --device): where the network runs; 'auto' (default) takes a GPU
    when libtorch sees one.
precision : {'auto', 'float32', 'bfloat16'} (nhnet.PRECISIONS, the default first)
    NH-Net only (nhnet-cli --precision): the network's arithmetic; 'bfloat16' runs it ~1.8x
    faster on CPUs with AVX512-BF16 or AMX (slower on others), normals within ~0.01 degree;
    'auto' takes bfloat16 where the CPU has AVX512-BF16 and the model supports it, else
    float32; 'float32' gives the same normals on every machine.
learned_fit : bool
    NH-Net only (nhnet-cli --learned-fit): refit each normal of the candidate mix by the learned
    weighted jet fit (default True); False keeps the mix's normals.
cell_means : bool, float or str
    nhnet-cli --cell-means: True (default) estimates a dense cloud whose noise exceeds its
    spacing (noise ratio >= 1.12, at least 200 000 points, automatic sizes) on local means of its
    points, each point taking its three nearest means' normals: several times faster there, as
    accurate or more; a number > 0 is the noise ratio from which; False always estimates the
    points themselves; nhnet-cli's words 'auto' and 'off' work too. `cell_means` on the
    result says which ran.
confidence : bool
    nhnet-cli --confidence: also compute each normal's confidence in [0, 1] (the result's
    `confidence`; default False: a second small neighbour search, a few % more time).

The GIL is released while the core runs; Ctrl-C interrupts it (KeyboardInterrupt).

Raises
------
nhnet.InvalidOptions (ValueError)
    Bad parameter or array shape.
nhnet.UnprocessableInput (ValueError)
    Fewer than 3 finite points.
)";

/// nhnet.EstimateResult: read-only views of the core's result.
void register_result(py::module_& m) {
  py::class_<PyEstimateResult>(m, "EstimateResult",
                               "Everything nhnet.estimate() computed for one cloud.")
      .def_readonly("normals", &PyEstimateResult::normals,
                    "(N, 3) float64 unit normals; NaN rows for failed points.")
      .def_readonly("valid", &PyEstimateResult::valid,
                    "(N,) bool: True where a normal was computed.")
      .def_readonly("curvature", &PyEstimateResult::curvature,
                    "(N,) float64 surface variation lambda_min / sum(lambda) of each point's "
                    "PCA neighbourhood (PCL's 'curvature'); NaN where failed.")
      .def_readonly("confidence", &PyEstimateResult::confidence,
                    "(N,) float64 confidence in [0, 1] of each normal: the chance that it is "
                    "within 30 degrees of the true normal, judged from its neighbourhood; NaN "
                    "where failed. None unless estimate(..., confidence=True).")
      .def_property_readonly("failed", core_field<PyEstimateResult>(&EstimateResult::failed),
                             "Number of False entries in `valid`.")
      .def_property_readonly("candidates",
                             core_field<PyEstimateResult>(&EstimateResult::candidates),
                             "Points classified as candidates near sharp features (MFPS only).")
      .def_property_readonly("noise_ratio",
                             core_field<PyEstimateResult>(&EstimateResult::noise_ratio),
                             "Estimated noise level: residual bandwidth / average spacing.")
      .def_property_readonly("spacing", core_field<PyEstimateResult>(&EstimateResult::spacing),
                             "Average distance to the nearest other point, input units.")
      .def_property_readonly("k_used", core_field<PyEstimateResult>(&EstimateResult::k_used),
                             "PCA neighbourhood size used.")
      .def_property_readonly("cell_means",
                             core_field<PyEstimateResult>(&EstimateResult::cell_means),
                             "Cell means the estimate ran on (see estimate's cell_means); 0 = "
                             "the points themselves.")
      .def_property_readonly("scales_used",
                             core_field<PyEstimateResult>(&EstimateResult::scales_used),
                             "MFPS patch sizes used (empty for PCA).")
      .def_property_readonly("warnings", core_field<PyEstimateResult>(&EstimateResult::warnings),
                             "Non-fatal notes (non-finite points skipped, clamped sizes, ...).")
      .def_property_readonly(
          "flipped", [](const PyEstimateResult& r) { return r.orient.flipped; },
          "Normals flipped by `orient` (0 without it).")
      .def_property_readonly(
          "unoriented", [](const PyEstimateResult& r) { return r.orient.unoriented; },
          "Valid normals whose sign `orient` could not decide (0 without it).")
      .def_readonly("orient_mode", &PyEstimateResult::orient_mode,
                    "The orientation applied ('auto' resolved: 'keep', 'viewpoint', 'none', ...).")
      .def_readonly("orient_source", &PyEstimateResult::orient_source,
                    "Why: 'sensor from PCD VIEWPOINT at (0, 0, 0)', 'input normals', ...")
      .def("__repr__", [](const PyEstimateResult& r) {
        return "<nhnet.EstimateResult points=" + std::to_string(r.normals.shape(0)) +
               " failed=" + std::to_string(r.core.failed) +
               " k_used=" + std::to_string(r.core.k_used) +
               " noise_ratio=" + std::to_string(r.core.noise_ratio) + ">";
      });
}

}  // namespace

/// nhnet.confidence_features / confidence_from_features (learned/confidence.hpp), for
/// tools/fit_confidence.py to fit and report on exactly what the core computes.
void register_confidence(py::module_& m) {
  py::enum_<ConfidenceModel>(m, "ConfidenceModel", "Whose confidence weights: the method's.")
      .value("pca", ConfidenceModel::Pca)
      .value("mfps", ConfidenceModel::Mfps)
      .value("nhnet", ConfidenceModel::NhNet);
  m.def(
      "confidence_features",
      [](const py::handle& points, const py::handle& normals, const py::handle& curvature,
         double noise_ratio, int threads) {
        const Points p = points_of(points);
        const Normals n = to_points(normals, "normals");
        const Eigen::VectorXd c = py::cast<Eigen::VectorXd>(curvature);
        if (n.rows() != p.rows() || c.size() != p.rows())
          throw InvalidOptions("points, normals and curvature differ in length");
        py::gil_scoped_release release;
        return confidence_features(p, n, c, noise_ratio, RunContext{threads, {}});
      },
      "(N, 8) features of the confidence of each normal (learned/confidence.hpp), NaN rows "
      "where the normal is not finite; `curvature` and `noise_ratio` as nhnet.estimate() "
      "returns them.",
      py::arg("points"), py::arg("normals"), py::arg("curvature"), py::arg("noise_ratio"),
      py::kw_only(), py::arg("threads") = 0);
  m.def(
      "confidence_from_features",
      [](const Eigen::MatrixXd& features, ConfidenceModel model) {
        if (features.cols() != kConfidenceFeatures)
          throw InvalidOptions("features must have " + std::to_string(kConfidenceFeatures) +
                               " columns");
        return confidence_from_features(features, model);
      },
      "Confidence in [0, 1] per row of confidence_features(), with the given method's weights.",
      py::arg("features"), py::arg("model"));
}

void register_estimate(py::module_& m) {
  register_result(m);
  register_confidence(m);
  py::tuple precisions(kPrecisions.size());
  for (size_t i = 0; i < kPrecisions.size(); ++i) precisions[i] = kPrecisions[i];
  m.attr("PRECISIONS") = precisions;  // estimate(precision=...), the default first
  const std::string estimate_doc =
      std::string(
          "Estimates unit normals and returns the full result (normals, valid mask, "
          "failed count, noise ratio, sizes used, warnings).\n") +
      kArgsDoc;
  // One argument list for estimate() and estimate_normals().
  // Defaults from the core's options (one place for every front end).
  const EstimateOptions defaults;
  const auto args = std::make_tuple(
      py::arg("points"), py::kw_only(), py::arg("method") = py::none(), py::arg("k") = defaults.k,
      py::arg("scales") = py::none(), py::arg("threads") = defaults.run.threads,
      py::arg("seed") = defaults.mfps.seed, py::arg("orient") = to_string(kDefaultOrientMode),
      py::arg("viewpoint") = py::none(), py::arg("progress") = py::none(),
      py::arg("refine") = to_string(defaults.model.refine), py::arg("model") = py::none(),
      py::arg("device") = defaults.model.device, py::arg("precision") = defaults.model.precision,
      py::arg("learned_fit") = defaults.model.learned_fit,
      py::arg("cell_means") = py::bool_(defaults.cell_means.noise_ratio > 0),
      py::arg("confidence") = defaults.confidence);
  std::apply([&](const auto&... a) { m.def("estimate", &estimate, estimate_doc.c_str(), a...); },
             args);

  const std::string normals_doc =
      std::string(
          "Estimates unit normals: returns an (N, 3) float64 array, NaN rows for points "
          "that failed. The core's warnings are issued as Python RuntimeWarnings; use "
          "nhnet.estimate() for the valid mask, the noise ratio and the sizes used.\n") +
      kArgsDoc;
  const auto estimate_normals =
      [](const py::handle& points, const std::optional<std::string>& method, int k,
         std::optional<std::vector<int>> scales, int threads, uint64_t seed,
         const py::object& orient, const py::object& viewpoint, const py::object& progress,
         const std::string& refine, const std::optional<std::string>& model,
         const std::string& device, const std::string& precision, bool learned_fit,
         const py::object& cell_means, bool confidence) {
        PyEstimateResult r = estimate(points, method, k, std::move(scales), threads, seed, orient,
                                      viewpoint, progress, refine, model, device, precision,
                                      learned_fit, cell_means, confidence);
        for (const std::string& w : r.core.warnings)
          if (PyErr_WarnEx(PyExc_RuntimeWarning, ("nhnet: " + w).c_str(), 1) != 0)
            throw py::error_already_set();
        return r.normals;
      };
  std::apply(
      [&](const auto&... a) {
        m.def("estimate_normals", estimate_normals, normals_doc.c_str(), a...);
      },
      args);
}

}  // namespace nhnet::python
