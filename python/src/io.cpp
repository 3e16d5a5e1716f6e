// Bindings of the point cloud io (io.hpp): nhnet.read() -> nhnet.Cloud, nhnet.write().
#include "bindings.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/io/cloud.hpp"
#include "nhnet/io/io.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace nhnet::python {

namespace {

struct TypeName {
  ScalarType type;
  const char* dtype;
};
const TypeName kTypes[] = {
    {ScalarType::Int8, "int8"},       {ScalarType::UInt8, "uint8"},
    {ScalarType::Int16, "int16"},     {ScalarType::UInt16, "uint16"},
    {ScalarType::Int32, "int32"},     {ScalarType::UInt32, "uint32"},
    {ScalarType::Float32, "float32"}, {ScalarType::Float64, "float64"},
};

FileFormat parse_format(const std::optional<std::string>& name) {
  if (!name) return FileFormat::Auto;
  if (*name == "ply") return FileFormat::Ply;
  if (*name == "pcd") return FileFormat::Pcd;
  if (*name == "xyz") return FileFormat::Xyz;
  if (*name == "las") return FileFormat::Las;
  if (*name == "laz") return FileFormat::Laz;
  if (*name == "e57") return FileFormat::E57;
  throw InvalidOptions("unknown format '" + *name +
                       "' (expected ply, pcd, xyz, las, laz, e57 or None)");
}

PyCloud read(const std::string& path, const std::optional<std::string>& format) {
  ReadOptions opt;
  opt.format = parse_format(format);
  std::vector<std::string> warnings;
  Cloud c;
  {
    py::gil_scoped_release release;
    c = read_cloud(path, opt, &warnings);
  }
  for (const std::string& w : warnings)
    if (PyErr_WarnEx(PyExc_RuntimeWarning, ("nhnet: " + w).c_str(), 1) != 0)
      throw py::error_already_set();
  PyCloud out;
  out.points = to_numpy(c.points);
  out.sensors = c.sensors;
  out.sensor_index = c.sensor_index;
  out.grid_width = c.grid_width;
  out.grid_height = c.grid_height;
  out.airborne = c.airborne;
  if (c.has_normals()) out.normals = to_numpy(c.normals);
  py::module_ np = py::module_::import("numpy");
  for (const ExtraProperty& e : c.extras) {
    const char* dtype = "float64";
    for (const TypeName& t : kTypes)
      if (t.type == e.type) dtype = t.dtype;
    py::array_t<double> values(py::ssize_t(e.values.size()), e.values.data());
    out.extras[py::str(e.name)] = values.attr("astype")(dtype);
  }
  return out;
}

ExtraProperty to_extra(const std::string& name, const py::handle& values, Eigen::Index n) {
  py::array a = py::array::ensure(values);
  if (!a) {
    PyErr_Clear();
    throw InvalidOptions("extra property '" + name + "' is not an array");
  }
  ExtraProperty e;
  e.name = name;
  const std::string dtype = py::str(a.dtype());
  bool known = dtype == "bool";
  e.type = ScalarType::UInt8;
  for (const TypeName& t : kTypes)
    if (dtype == t.dtype) {
      e.type = t.type;
      known = true;
    }
  if (!known)
    throw InvalidOptions("extra property '" + name + "' has dtype " + dtype +
                         "; files hold int8..int32, uint8..uint32, float32, float64 (cast it, "
                         "e.g. .astype(numpy.int32))");
  if (a.ndim() != 1 || a.shape(0) != n)
    throw InvalidOptions("extra property '" + name + "' must be a 1-D array of " +
                         std::to_string(n) + " values (one per point)");
  auto d = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  e.values.assign(d.data(), d.data() + n);
  return e;
}

void write(const std::string& path, const py::object& points, const py::object& normals,
           const py::object& extras, bool ascii, const std::optional<std::string>& format,
           const py::object& confidence) {
  Cloud c;
  py::object pts = points, nrm = normals, ext = extras;
  if (py::isinstance<PyCloud>(points)) {  // write(path, cloud): the cloud's own fields
    const PyCloud& pc = points.cast<const PyCloud&>();
    pts = pc.points;
    if (nrm.is_none()) nrm = pc.normals;
    if (ext.is_none()) ext = pc.extras;
    c.sensors = pc.sensors;
    c.sensor_index = pc.sensor_index;
    c.grid_width = pc.grid_width;
    c.grid_height = pc.grid_height;
    c.airborne = pc.airborne;
  }
  c.points = to_points(pts, "points");
  if (!nrm.is_none()) {
    c.normals = to_points(nrm, "normals");
    if (c.normals.rows() != c.points.rows())
      throw InvalidOptions("normals must have one row per point: got " +
                           std::to_string(c.normals.rows()) + " for " +
                           std::to_string(c.points.rows()) + " points");
  }
  if (!ext.is_none())
    for (auto item : ext.cast<py::dict>())
      c.extras.push_back(to_extra(py::str(item.first), item.second, c.points.rows()));
  if (!confidence.is_none()) {
    c.confidence = py::cast<Eigen::VectorXd>(confidence);
    if (c.confidence.size() != c.points.rows())
      throw InvalidOptions("confidence must have one value per point: got " +
                           std::to_string(c.confidence.size()) + " for " +
                           std::to_string(c.points.rows()) + " points");
  }
  WriteOptions opt;
  opt.format = parse_format(format);
  opt.ascii = ascii;
  py::gil_scoped_release release;
  write_cloud(path, c, opt);
}

py::array_t<double> vector_numpy(const Eigen::Vector3d& v) {
  py::array_t<double> a(3);
  for (int i = 0; i < 3; ++i) a.mutable_data()[i] = v[i];
  return a;
}

/// The nhnet.Sensor class and the sensor fields of nhnet.Cloud.
void register_sensor(py::module_& m) {
  py::class_<Sensor>(m, "Sensor",
                     "A sensor the file names (PCD VIEWPOINT, PLY camera element, ...): "
                     "`position` (3,), `rotation` (3, 3; columns = the sensor's axes in the "
                     "points' frame), `source` (for reports).")
      .def(py::init([](const py::handle& position, const py::handle& rotation) {
             Sensor s;
             const Points p = to_points(
                 py::module_::import("numpy").attr("reshape")(position, py::make_tuple(1, 3)),
                 "position");
             s.position = p.row(0).transpose();
             if (!rotation.is_none()) {
               const Points r = to_points(rotation, "rotation");
               if (r.rows() != 3) throw InvalidOptions("rotation must be a (3, 3) array");
               s.rotation = r;
             }
             s.source = "Python";
             return s;
           }),
           py::arg("position"), py::arg("rotation") = py::none())
      .def_property_readonly("position", [](const Sensor& s) { return vector_numpy(s.position); })
      .def_property_readonly("rotation",
                             [](const Sensor& s) {
                               Points r = s.rotation;
                               return to_numpy(r);
                             })
      .def_readonly("source", &Sensor::source)
      .def("__repr__", [](const Sensor& s) {
        return "<nhnet.Sensor at (" + std::to_string(s.position.x()) + ", " +
               std::to_string(s.position.y()) + ", " + std::to_string(s.position.z()) + ") from " +
               s.source + ">";
      });
}

}  // namespace

Cloud core_cloud(const PyCloud& pc) {
  Cloud c;
  c.points = to_points(pc.points, "points");
  if (!pc.normals.is_none()) c.normals = to_points(pc.normals, "normals");
  c.sensors = pc.sensors;
  c.sensor_index = pc.sensor_index;
  c.grid_width = pc.grid_width;
  c.grid_height = pc.grid_height;
  c.airborne = pc.airborne;
  return c;
}

void register_io(py::module_& m) {
  register_sensor(m);
  py::class_<PyCloud>(m, "Cloud",
                      "A point cloud as read by nhnet.read(): `points` (N, 3) float64, "
                      "`normals` (N, 3) float64 or None, `extras` {name: (N,) array} holding the "
                      "file's other per-point properties (colour, intensity, ...) in their "
                      "declared types.")
      .def(py::init(
               [](const py::object& points, const py::object& normals, const py::object& extras) {
                 PyCloud c;
                 c.points = points;
                 c.normals = normals;
                 if (!extras.is_none()) c.extras = extras.cast<py::dict>();
                 return c;
               }),
           py::arg("points"), py::arg("normals") = py::none(), py::arg("extras") = py::none())
      .def_readwrite("points", &PyCloud::points, "(N, 3) float64 coordinates.")
      .def_readwrite("normals", &PyCloud::normals, "(N, 3) float64 normals or None.")
      .def_readwrite("extras", &PyCloud::extras, "{name: (N,) array} other properties.")
      .def_readwrite("sensors", &PyCloud::sensors,
                     "[nhnet.Sensor] the sensors the file names (empty: none known); what "
                     "orient='auto' turns the normals towards.")
      .def_readwrite("sensor_index", &PyCloud::sensor_index,
                     "Per point, its sensor's index into `sensors` (empty: all sensors[0]).")
      .def_property(
          "grid",
          [](const PyCloud& c) -> py::object {
            if (c.grid_width <= 0 || c.grid_height <= 0) return py::none();
            return py::make_tuple(c.grid_width, c.grid_height);
          },
          [](PyCloud& c, const py::object& g) {
            const auto wh =
                g.is_none() ? std::vector<int64_t>{0, 0} : g.cast<std::vector<int64_t>>();
            if (wh.size() != 2) throw InvalidOptions("grid must be (width, height) or None");
            c.grid_width = wh[0];
            c.grid_height = wh[1];
          },
          "(width, height) of an organized cloud (a depth image, row-major), or None.")
      .def_readwrite("airborne", &PyCloud::airborne,
                     "Taken from above with no known sensor (airborne LiDAR): orient='auto' "
                     "turns normals up.")
      .def("__len__", [](const PyCloud& c) { return py::len(c.points); })
      .def("__repr__", [](const PyCloud& c) {
        return "<nhnet.Cloud points=" + std::to_string(py::len(c.points)) +
               (c.normals.is_none() ? " no normals" : " with normals") +
               " extras=" + std::string(py::str(py::list(c.extras.attr("keys")()))) + ">";
      });

  m.def("read", &read,
        "Reads a PLY (ascii / binary), PCD (ascii / binary / binary_compressed) or XYZ text "
        "file. `format` ('ply', 'pcd', 'xyz') overrides the detection by content and "
        "extension. Non-finite coordinates are kept as they are. Non-fatal notes (e.g. a "
        "dropped face element) are issued as RuntimeWarnings.\n\n"
        "Raises nhnet.InputError (a ValueError and an OSError) naming the file and the "
        "problem: missing, unreadable, empty, truncated, malformed (with the line or byte).",
        py::arg("path"), py::arg("format") = py::none());
  m.def("write", &write,
        "Writes a cloud: `points` (N, 3) and optional `normals` (N, 3) as arrays, or a "
        "nhnet.Cloud as `points` (its normals and extras are used unless given). `extras` "
        "maps property names to (N,) arrays (PLY / PCD only; their dtype is the stored type). "
        "The format comes from the extension (.ply, .pcd, .xyz/.xyzn/.txt/.pts) unless "
        "`format` says; PLY / PCD are binary unless `ascii`. The file is written to a "
        "temporary name and renamed over `path` when complete (an existing file is "
        "replaced; a failure leaves no partial file). `confidence` (N,), e.g. "
        "nhnet.estimate(..., confidence=True).confidence, is written as nhnet-cli --confidence "
        "writes it (PLY / PCD `confidence`, LAS / LAZ `Confidence`, E57 `nhnet:confidence`, "
        "XYZ a 7th column; needs the normals).\n\n"
        "Raises nhnet.OutputError (an OSError) naming the file and the reason, "
        "nhnet.InvalidOptions (a ValueError) for bad arrays.",
        py::arg("path"), py::arg("points"), py::arg("normals") = py::none(), py::kw_only(),
        py::arg("extras") = py::none(), py::arg("ascii") = false, py::arg("format") = py::none(),
        py::arg("confidence") = py::none());
}

}  // namespace nhnet::python
