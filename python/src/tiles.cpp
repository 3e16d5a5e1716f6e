// Bindings of the tiled run's steps (tiles.hpp) for nhnet.distributed: private functions
// (leading underscore) that take and return numpy arrays, plain numbers and dicts, so that Dask
// can ship their inputs and results between processes.
#include "bindings.hpp"
#include "dict_fields.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/orient/sides_grid.hpp"
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

py::dict grid_to_dict(const SidesGrid& g) {
  py::dict d;
  d["origin"] = to_numpy(Points(g.origin));
  d["h"] = g.h;
  d["dilation"] = g.dilation;
  d["dims"] = std::vector<int64_t>(g.dims.begin(), g.dims.end());
  return d;
}

/// A SidesGrid from grid_to_dict's fields, with d["cell"] (uint8 array) when `cells`.
SidesGrid grid_from_dict(const py::dict& d, bool cells) {
  SidesGrid g;
  g.origin = row3(d["origin"], "grid origin");
  g.h = d["h"].cast<double>();
  g.dilation = d["dilation"].cast<int>();
  const auto dims = d["dims"].cast<std::vector<int64_t>>();
  if (dims.size() != 3) throw InvalidOptions("sides grid: dims must be 3 numbers");
  std::copy(dims.begin(), dims.end(), g.dims.begin());
  if (cells) {
    const auto c =
        py::array_t<uint8_t, py::array::c_style | py::array::forcecast>::ensure(d["cell"]);
    if (!c) throw InvalidOptions("sides grid: cell must be a uint8 array");
    g.cell.assign(c.data(), c.data() + c.size());
  }
  return g;
}

/// The MST options of a tile: k neighbours, threads, the whole cloud's grid when given.
OrientOptions mst_options(int k, int threads, const py::object& grid, bool inside_outside) {
  OrientOptions o;
  o.mode = OrientMode::Mst;
  o.k = k;
  o.run.threads = threads;
  o.inside_outside = inside_outside;
  if (!grid.is_none())
    o.sides = std::make_shared<const SidesGrid>(grid_from_dict(grid.cast<py::dict>(), true));
  return o;
}

/// TileDecisions as the dict nhnet.distributed ships between processes (both directions).
const auto kDecisionFields = std::make_tuple(
    field("noise_ratio", &TileDecisions::noise_ratio), field("spacing", &TileDecisions::spacing),
    field("far_radius", &TileDecisions::far_radius), field("far_k", &TileDecisions::far_k),
    field("k_smooth", &TileDecisions::k_smooth), field("scales", &TileDecisions::scales),
    field("halo", &TileDecisions::halo), field("variation_halo", &TileDecisions::variation_halo),
    field("variation_threshold", &TileDecisions::variation_threshold),
    field("cell_means", &TileDecisions::cell_means));

/// The estimator's options from the job's (a dict: method, k, scales, seed, threads, halo, model,
/// device, and optionally precision, cell_means (a noise ratio, 0 = off) and confidence (bool):
/// None or absent = the core's).
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
  if (d.contains("precision") && !d["precision"].is_none())
    o.model.precision = d["precision"].cast<std::string>();
  if (d.contains("cell_means") && !d["cell_means"].is_none())
    o.cell_means.noise_ratio = d["cell_means"].cast<double>();
  if (d.contains("confidence") && !d["confidence"].is_none())
    o.confidence = d["confidence"].cast<bool>();
  return o;
}

py::dict decide(const std::vector<std::tuple<DistanceMatrix, ProbeResiduals>>& rows,
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
  py::object confidence = py::none();
  if (o.confidence) confidence = to_numpy(r.confidence);
  return py::make_tuple(to_numpy(r.normals), to_numpy_mask(r.valid), to_numpy(r.candidate),
                        r.warnings, r.k_used, r.scales_used, r.cell_means, confidence);
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
  m.def(
      "_default_confidence", [] { return EstimateOptions{}.confidence; },
      "The core's default of EstimateOptions::confidence (nhnet-cli --confidence's).");
  m.def("_cell_means_ratio", &cell_means_from_string,
        "The noise ratio of nhnet-cli's --cell-means text (auto, off = 0 or a ratio > 0).");
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
      "Noise-probe rows (d2 float32 (R, K), residuals (R, 2)) of one tile (tiles.hpp).");
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
  m.def(
      "_sides_grid_plan",
      [](const py::handle& lo, const py::handle& hi, double spacing, double typical) {
        const SidesGridPlan p = sides_grid_plan(row3(lo, "lo"), row3(hi, "hi"), spacing, typical);
        return py::make_tuple(p.h, p.dilation, p.max_leak);
      },
      "(voxel sizes, dilations, max_leak) of the flood-fill grids the MST tries for a cloud "
      "(sides_grid.hpp).");
  m.def(
      "_sides_grid_frame",
      [](const py::handle& lo, const py::handle& hi, double h, int dilation) {
        SidesGrid g = sides_grid_frame(row3(lo, "lo"), row3(hi, "hi"), h, dilation);
        return grid_to_dict(g);
      },
      "The flood-fill grid's frame (dict: origin, h, dilation, dims) over a box (sides_grid.hpp).");
  m.def(
      "_sides_grid_voxels",
      [](const py::dict& grid, const py::handle& points) {
        const std::vector<int64_t> v =
            sides_grid_voxels(grid_from_dict(grid, false), to_points(points, "points"));
        return py::array_t<int64_t>(py::ssize_t(v.size()), v.data());
      },
      "The voxel index of each point in a grid frame from _sides_grid_frame.");
  m.def(
      "_fill_sides_grid",
      [](const py::dict& grid, const py::handle& occupied) {
        SidesGrid g = grid_from_dict(grid, false);
        g.cell.assign(size_t(g.dims[0] * g.dims[1] * g.dims[2]), 0);
        const auto occ =
            py::array_t<int64_t, py::array::c_style | py::array::forcecast>::ensure(occupied);
        if (!occ || occ.ndim() != 1)
          throw InvalidOptions("sides grid: occupied must be a 1-D array of voxel indices");
        {
          py::gil_scoped_release release;
          fill_sides_grid(g, std::vector<int64_t>(occ.data(), occ.data() + occ.size()));
        }
        return py::array_t<uint8_t>(py::ssize_t(g.cell.size()), g.cell.data());
      },
      "The cells (uint8, 2 = outside) of a grid frame with the occupied voxels, dilated and "
      "flood-filled.");
  m.def(
      "_mst_guides",
      [](const py::handle& points, const py::handle& normals, int64_t own, int k, int threads) {
        const Points p = to_points(points, "points");
        const Normals n = to_points(normals, "normals");
        MstGuides g;
        {
          py::gil_scoped_release release;
          g = mst_guides(p, n, own, mst_options(k, threads, py::none(), true));
        }
        return py::make_tuple(to_numpy(g.points), to_numpy(g.guides),
                              py::array_t<double>(py::ssize_t(g.nearest.size()), g.nearest.data()),
                              to_numpy(g.row_guides));
      },
      "(points, guides, nearest, row_guides) of a tile: its distinct valid own points, their "
      "guides and nearest distances, and every row's guide (orient.hpp mst_guides).");
  m.def(
      "_sides_leaked",
      [](const py::handle& points, const py::handle& guides, const py::dict& grid, int threads,
         int64_t limit) {
        const Points p = to_points(points, "points");
        const Normals g = to_points(guides, "guides");
        const SidesGrid grid_cells = grid_from_dict(grid, true);
        py::gil_scoped_release release;
        return sides_leaked(p, g, grid_cells, threads, limit);
      },
      "How many points leak on a grid with cells, counted until `limit` when > 0 (orient.hpp "
      "sides_leaked).",
      py::arg("points"), py::arg("guides"), py::arg("grid"), py::arg("threads"),
      py::arg("limit") = 0);
  m.def(
      "_orient_mst_tile",
      [](const py::handle& points, const py::handle& normals, int k, int threads,
         const py::object& grid, bool inside_outside, const py::object& guides) {
        const Points p = to_points(points, "points");
        Normals n = to_points(normals, "normals");
        OrientOptions o = mst_options(k, threads, grid, inside_outside);
        if (!guides.is_none())
          o.guides = std::make_shared<const Normals>(to_points(guides, "guides"));
        {
          py::gil_scoped_release release;
          orient_normals(p, n, o);
        }
        return to_numpy(n);
      },
      "A tile's normals oriented by the MST, voting on the whole cloud's grid (dict with cell) "
      "when given, with no flood fill when inside_outside is False, on every row's guide from "
      "_mst_guides when given (else fitted here).",
      py::arg("points"), py::arg("normals"), py::arg("k"), py::arg("threads"), py::arg("grid"),
      py::arg("inside_outside"), py::arg("guides") = py::none());
  m.def("_estimate_tile", &estimate,
        "One tile (own points then halo, frame units) with the whole cloud's decisions: "
        "(normals, valid, candidate, warnings, k_used, scales_used, cell_means, confidence: None "
        "unless the options ask for it).");
}

}  // namespace nhnet::python
