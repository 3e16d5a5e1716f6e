// Bindings of the tiled run's steps (tiles.hpp) for nhnet.distributed: private functions
// (leading underscore) that take and return numpy arrays, plain numbers and dicts, so that Dask
// can ship their inputs and results between processes.
#include "bindings.hpp"
#include "dict_fields.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/tiles.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <optional>
#include <tuple>

namespace nhnet::python {

namespace {

Eigen::RowVector3d row3(const py::handle& a, const char* what) {
  const Points p =
      to_points(py::module_::import("numpy").attr("reshape")(a, py::make_tuple(1, 3)), what);
  return p.row(0);
}

py::dict plan_to_dict(const TilePlan& p) {
  py::dict d;
  d["axis"] = to_numpy(p.axis);
  d["value"] = to_numpy(p.value);
  d["left"] = to_numpy(p.left);
  d["right"] = to_numpy(p.right);
  d["leaf"] = to_numpy(p.leaf);
  d["cell_lo"] = to_numpy(p.cell_lo);
  d["cell_hi"] = to_numpy(p.cell_hi);
  return d;
}

TilePlan plan_from_dict(const py::dict& d) {
  TilePlan p;
  p.axis = d["axis"].cast<std::vector<int>>();
  p.value = d["value"].cast<std::vector<double>>();
  p.left = d["left"].cast<std::vector<int>>();
  p.right = d["right"].cast<std::vector<int>>();
  p.leaf = d["leaf"].cast<std::vector<int>>();
  return p;
}

/// TileDecisions as the dict nhnet.distributed ships between processes (both directions).
const auto kDecisionFields = std::make_tuple(
    field("noise_ratio", &TileDecisions::noise_ratio), field("spacing", &TileDecisions::spacing),
    field("far_radius", &TileDecisions::far_radius), field("far_k", &TileDecisions::far_k),
    field("k_smooth", &TileDecisions::k_smooth), field("scales", &TileDecisions::scales),
    field("halo", &TileDecisions::halo), field("variation_halo", &TileDecisions::variation_halo),
    field("variation_threshold", &TileDecisions::variation_threshold));

/// The estimator's options from the job's (a dict: method, k, scales, seed, threads, halo, model,
/// device).
EstimateOptions options_from_dict(const py::dict& d) {
  EstimateOptions o;
  o.method = method_from_string(d["method"].cast<std::string>());
  o.k = d["k"].cast<int>();
  if (!d["scales"].is_none()) o.mfps.scales = d["scales"].cast<std::vector<int>>();
  o.mfps.seed = d["seed"].cast<uint64_t>();
  o.run.threads = d["threads"].cast<int>();
  o.tiles.halo = d["halo"].cast<double>();
  if (!d["model"].is_none()) o.model.path = d["model"].cast<std::string>();
  o.model.device = d["device"].cast<std::string>();
  return o;
}

py::dict decide(const std::vector<std::tuple<DistanceMatrix, Eigen::VectorXd>>& rows,
                const py::dict& options, int64_t finite) {
  std::vector<TileProbeRows> r;
  for (const auto& [d2, residual] : rows) r.push_back({d2, residual});
  return fields_to_dict(decide_tiles(r, options_from_dict(options), finite), kDecisionFields);
}

py::tuple estimate(const py::handle& points, const py::dict& options, const py::dict& decisions) {
  const Points pts = to_points(points, "points");
  const EstimateOptions o = options_from_dict(options);
  const auto d = fields_from_dict<TileDecisions>(decisions, kDecisionFields);
  EstimateResult r;
  {
    py::gil_scoped_release release;
    r = estimate_tile(pts, o, d);
  }
  return py::make_tuple(to_numpy(r.normals), to_numpy_mask(r.valid), to_numpy(r.candidate),
                        r.warnings, r.k_used, r.scales_used);
}

}  // namespace

void register_tiles(py::module_& m) {
  m.def(
      "_tile_frame",
      [](const py::handle& lo, const py::handle& hi) {
        const TileFrame f = tile_frame(row3(lo, "lo"), row3(hi, "hi"));
        return py::make_tuple(to_numpy(Points(f.centre)), f.scale);
      },
      "(centre (1, 3), scale) of the tiles' frame for the bounding box [lo, hi] (tiles.hpp).");
  m.def(
      "_plan_tiles",
      [](const py::handle& sample, int64_t finite, int64_t tile_points) {
        const Points s = to_points(sample, "sample");
        return plan_to_dict(plan_tiles(s, finite, tile_points));
      },
      "The tile plan (dict of arrays) placed on a sample in frame units (tiles.hpp).");
  m.def(
      "_route_tiles",
      [](const py::dict& plan, const py::handle& points) {
        const Points p = to_points(points, "points");
        return to_numpy(route_tiles(plan_from_dict(plan), p));
      },
      "The tile of each point (frame units) under a plan from _plan_tiles.");
  m.def(
      "_default_method",
      [] {
        std::string why;
        const Method chosen = default_method(&why);
        return py::make_tuple(std::string(to_string(chosen)), why);
      },
      "(name, why) of the core's default method (estimate.hpp default_method(); why is empty "
      "unless it fell back to MFPS): every front end's default.");
  m.def("_probe_step", &probe_step);
  m.def("_variation_step", &variation_step);
  m.def(
      "_probe_tile",
      [](const py::handle& points, int64_t own, int64_t step, double halo, const py::handle& lo,
         const py::handle& hi, int threads) {
        const Points p = to_points(points, "points");
        const Eigen::RowVector3d cell_lo = row3(lo, "cell_lo"), cell_hi = row3(hi, "cell_hi");
        TileProbeRows r;
        {
          py::gil_scoped_release release;
          r = probe_tile(p, own, step, halo, cell_lo, cell_hi, threads);
        }
        return py::make_tuple(to_numpy(r.d2), to_numpy(r.residual));
      },
      "Noise-probe rows (d2 float32 (R, K), residual (R,)) of one tile (tiles.hpp).");
  m.def("_decide_tiles", &decide,
        "The whole cloud's decisions (dict) from every tile's probe rows (tiles.hpp).");
  m.def(
      "_tile_variation",
      [](const py::handle& points, int64_t own, int k_smooth, int64_t step, int threads) {
        const Points p = to_points(points, "points");
        Eigen::VectorXd v;
        {
          py::gil_scoped_release release;
          v = tile_variation(p, own, k_smooth, step, threads);
        }
        return to_numpy(v);
      },
      "Surface variations of a tile's own distinct points (tiles.hpp).");
  m.def(
      "_variation_threshold", [](const Eigen::VectorXd& v) { return variation_threshold(v); },
      "MFPS's candidate threshold from surface variations.");
  m.def("_estimate_tile", &estimate,
        "One tile (own points then halo, frame units) with the whole cloud's decisions: "
        "(normals, valid, candidate, warnings, k_used, scales_used).");
}

}  // namespace nhnet::python
