// Bindings of the orientation stage (orient.hpp): nhnet.orient(), and the orientation request
// shared with nhnet.estimate(orient=...).
#include "bindings.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"

#include <pybind11/stl.h>

namespace nhnet::python {

OrientRequest orient_request(const py::object& orient, const py::object& reference,
                             const py::object& viewpoint, int k, Eigen::Index n) {
  OrientRequest req;
  req.options.k = k;
  if (orient.is_none()) {
    req.options.mode = OrientMode::None;
  } else if (py::isinstance<py::str>(orient)) {
    req.options.mode = orient_mode_from_string(orient.cast<std::string>());
  } else {
    req.options.mode = OrientMode::Keep;
    req.reference = to_points(orient, "orient (reference normals)");
  }
  if (!reference.is_none()) {
    if (req.options.mode != OrientMode::Keep || req.reference.rows() > 0)
      throw InvalidOptions("reference normals are only used with orient='keep'");
    req.reference = to_points(reference, "reference");
  }
  if (req.options.mode == OrientMode::Keep) {
    if (req.reference.rows() != n)
      throw InvalidOptions("orient 'keep' needs one reference normal per point: got " +
                           std::to_string(req.reference.rows()) + " for " + std::to_string(n) +
                           " points");
  }
  if (!viewpoint.is_none()) {
    if (req.options.mode != OrientMode::Viewpoint)
      throw InvalidOptions("viewpoint is only used with orient='viewpoint'");
    const auto v = viewpoint.cast<std::vector<double>>();
    if (v.size() != 3)
      throw InvalidOptions("viewpoint must be 3 numbers (x, y, z), got " +
                           std::to_string(v.size()));
    req.options.viewpoint = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  return req;
}

void resolve_request(OrientRequest& req, const py::handle& points, OrientMode array_mode) {
  if (req.options.mode != OrientMode::Auto) {
    req.source = "requested";
    return;
  }
  if (!py::isinstance<PyCloud>(points)) {
    req.options.mode = array_mode;
    req.source = std::string("an array names no sensor: ") + to_string(array_mode);
    return;
  }
  const Cloud cloud = core_cloud(points.cast<const PyCloud&>());
  OrientPlan plan = resolve_orientation(cloud, req.options);
  req.options = plan.options;
  req.source = plan.source;
  if (req.options.mode == OrientMode::Keep) req.reference = cloud.normals;
}

/// The points of an array or of an nhnet.Cloud.
Points points_of(const py::handle& points) {
  if (py::isinstance<PyCloud>(points))
    return to_points(points.cast<const PyCloud&>().points, "cloud.points");
  return to_points(points, "points");
}

namespace {

struct PyOrientResult {
  OrientResult core;
  py::array_t<double> normals;
  std::string mode, source;  ///< the orientation applied and why
};

PyOrientResult orient(const py::handle& points, const py::handle& normals, const py::object& mode,
                      const py::object& reference, const py::object& viewpoint, int k, int threads,
                      const py::object& progress) {
  const Points pts = points_of(points);
  Normals nrm = to_points(normals, "normals");
  if (nrm.rows() != pts.rows())
    throw InvalidOptions("normals must have one row per point: got " + std::to_string(nrm.rows()) +
                         " for " + std::to_string(pts.rows()) + " points");
  OrientRequest req = orient_request(mode, reference, viewpoint, k, pts.rows());
  resolve_request(req, points, OrientMode::Mst);
  req.options.run.threads = threads;
  PyOrientResult out;
  out.mode = to_string(req.options.mode);
  out.source = req.source;
  out.core = run_released(progress, [&](ProgressCallback cb) {
    req.options.run.progress = std::move(cb);
    return orient_normals(pts, nrm, req.options, req.reference);
  });
  out.normals = to_numpy(nrm);
  return out;
}

}  // namespace

void register_orient(py::module_& m) {
  py::class_<PyOrientResult>(m, "OrientResult", "What nhnet.orient() did.")
      .def_readonly("normals", &PyOrientResult::normals,
                    "(N, 3) float64 oriented normals (a new array; rows in the input's order).")
      .def_property_readonly("flipped", core_field<PyOrientResult>(&OrientResult::flipped),
                             "Normals whose sign was changed.")
      .def_property_readonly("unoriented", core_field<PyOrientResult>(&OrientResult::unoriented),
                             "Valid normals whose sign could not be decided (left as they were).")
      .def_property_readonly("invalid", core_field<PyOrientResult>(&OrientResult::invalid),
                             "NaN / zero normals or non-finite points (never touched).")
      .def_property_readonly("components", core_field<PyOrientResult>(&OrientResult::components),
                             "'mst': connected components of the k-NN graph.")
      .def_property_readonly("unoriented_components",
                             core_field<PyOrientResult>(&OrientResult::unoriented_components),
                             "'mst': components that could not be oriented completely.")
      .def_property_readonly("completed", core_field<PyOrientResult>(&OrientResult::completed),
                             "'mst': points CGAL left out inside a connected component, oriented "
                             "from a neighbour.")
      .def_property_readonly("inside_outside_votes",
                             core_field<PyOrientResult>(&OrientResult::inside_outside_votes),
                             "'mst': points whose side the voxel flood fill decided (0 when the "
                             "cloud is open).")
      .def_property_readonly("voxel", core_field<PyOrientResult>(&OrientResult::voxel),
                             "'mst': voxel size of the flood fill's grid (points' units; 0 = no "
                             "watertight grid, the tree alone decided).")
      .def_readonly("mode", &PyOrientResult::mode,
                    "The orientation applied ('auto' resolved: 'keep', 'viewpoint', ...).")
      .def_readonly("source", &PyOrientResult::source,
                    "Why: 'sensor from PCD VIEWPOINT at (0, 0, 0)', 'input normals', ...")
      .def("__repr__", [](const PyOrientResult& r) {
        return "<nhnet.OrientResult flipped=" + std::to_string(r.core.flipped) +
               " unoriented=" + std::to_string(r.core.unoriented) +
               " invalid=" + std::to_string(r.core.invalid) + ">";
      });

  m.def("orient", &orient,
        "Orients normals (consistent signs); returns an OrientResult whose `normals` is a new "
        "(N, 3) array in the input's order.\n\n"
        "points : (N, 3) array or an nhnet.Cloud (from nhnet.read).\n"
        "mode : 'auto' (default): for an nhnet.Cloud, what its file says, as nhnet-cli "
        "(its normals' signs, else towards its sensor or an organized grid's origin, else 'up' "
        "for airborne scans, else 'mst'); for an array 'mst'. 'mst' propagates signs over a "
        "minimum spanning tree of the k-NN graph "
        "(Hoppe et al. 1992, CGAL's mst_orient_normals, once per connected component; outward on "
        "a closed surface, where a voxel flood fill first decides each point's outside and the "
        "tree grows from those points: see OrientResult.inside_outside_votes); 'viewpoint' "
        "turns every normal towards `viewpoint` (x, y, z; default the origin); 'up' turns "
        "normals to +z where the surface is not near vertical (airborne scans), the rest by "
        "the tree; 'keep' makes each "
        "normal agree with `reference` (N, 3); 'none' changes "
        "nothing.\n"
        "k : neighbours per point of the 'mst' graph (default 18, at least 2).\n"
        "threads, progress : as in nhnet.estimate(); the GIL is released, Ctrl-C interrupts.\n\n"
        "Raises nhnet.InvalidOptions (a ValueError) for bad options or mismatched sizes.",
        py::arg("points"), py::arg("normals"), py::arg("mode") = to_string(kDefaultOrientMode),
        py::kw_only(), py::arg("reference") = py::none(), py::arg("viewpoint") = py::none(),
        py::arg("k") = OrientOptions().k, py::arg("threads") = OrientOptions().run.threads,
        py::arg("progress") = py::none());
}

}  // namespace nhnet::python
