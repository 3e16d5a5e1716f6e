// Bindings of the normal-guided denoiser (denoise.hpp, paper Sec. 7 Eq. 9): nhnet.denoise().
#include "bindings.hpp"

#include "nhnet/denoise/denoise.hpp"
#include "nhnet/errors.hpp"

#include <pybind11/stl.h>

namespace nhnet::python {

namespace {

struct PyDenoiseResult {
  DenoiseResult core;
  py::array_t<double> points;
};

PyDenoiseResult denoise(const py::handle& points, const py::handle& normals, int iterations,
                        double radius, double radius_factor, double sigma, int threads,
                        const py::object& progress) {
  const Points pts = to_points(points, "points");
  const Normals nrm = to_points(normals, "normals");
  DenoiseOptions opt;
  opt.iterations = iterations;
  opt.radius = radius;
  opt.radius_factor = radius_factor;
  opt.sigma = sigma;
  opt.run.threads = threads;
  PyDenoiseResult out;
  out.core = run_released(progress, [&](ProgressCallback cb) {
    opt.run.progress = std::move(cb);
    return denoise_points(pts, nrm, opt);
  });
  out.points = to_numpy(out.core.points);
  out.core.points.resize(0, 3);
  return out;
}

}  // namespace

void register_denoise(py::module_& m) {
  const DenoiseOptions defaults;
  py::class_<PyDenoiseResult>(m, "DenoiseResult", "What nhnet.denoise() computed.")
      .def_readonly("points", &PyDenoiseResult::points,
                    "(N, 3) float64 denoised points in the input's order; points not moved keep "
                    "their input coordinates.")
      .def_property_readonly("moved", core_field<PyDenoiseResult>(&DenoiseResult::moved),
                             "Points updated.")
      .def_property_readonly("skipped", core_field<PyDenoiseResult>(&DenoiseResult::skipped),
                             "Points left in place: non-finite, or NaN / zero normal.")
      .def_property_readonly("isolated", core_field<PyDenoiseResult>(&DenoiseResult::isolated),
                             "Points left in place: no other usable point in their ball.")
      .def_property_readonly("radius", core_field<PyDenoiseResult>(&DenoiseResult::radius),
                             "Ball radius used, input units.")
      .def_property_readonly("sigma", core_field<PyDenoiseResult>(&DenoiseResult::sigma),
                             "Normal bandwidth used.")
      .def_property_readonly("spacing", core_field<PyDenoiseResult>(&DenoiseResult::spacing),
                             "Average spacing the default radius came from.")
      .def_property_readonly("mean_neighbors",
                             core_field<PyDenoiseResult>(&DenoiseResult::mean_neighbors),
                             "Mean ball size over the moved points.")
      .def_property_readonly("warnings", core_field<PyDenoiseResult>(&DenoiseResult::warnings),
                             "Non-fatal notes (capped neighbourhoods, ...).")
      .def("__repr__", [](const PyDenoiseResult& r) {
        return "<nhnet.DenoiseResult moved=" + std::to_string(r.core.moved) +
               " radius=" + std::to_string(r.core.radius) + ">";
      });

  m.def("denoise", &denoise,
        "Moves points onto the surface their normals describe (paper Sec. 7, Eq. 9): "
        "`iterations` update steps over ball neighbourhoods fixed on the input. Returns a "
        "DenoiseResult whose `points` is a new (N, 3) array in the input's order.\n\n"
        "normals : (N, 3), e.g. from nhnet.estimate_normals(); any sign, any length. Points "
        "that are non-finite or whose normal is NaN / zero neither move nor act as neighbours.\n"
        "iterations : update steps (paper: 20).\n"
        "radius : ball radius in input units; 0 (default) = radius_factor x average spacing.\n"
        "radius_factor : default radius as a multiple of the average spacing (2).\n"
        "sigma : bandwidth of the normal-difference weight (0.35).\n"
        "threads, progress : as in nhnet.estimate(); the GIL is released, Ctrl-C interrupts.\n\n"
        "Raises nhnet.InvalidOptions (a ValueError) for bad options or mismatched sizes, "
        "nhnet.UnprocessableInput (a ValueError) when fewer than 2 usable points remain.",
        py::arg("points"), py::arg("normals"), py::kw_only(),
        py::arg("iterations") = defaults.iterations, py::arg("radius") = defaults.radius,
        py::arg("radius_factor") = defaults.radius_factor, py::arg("sigma") = defaults.sigma,
        py::arg("threads") = defaults.run.threads, py::arg("progress") = py::none());
}

}  // namespace nhnet::python
