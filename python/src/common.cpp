// Array conversion, the progress bridge (GIL, Ctrl-C, user callback) and the mapping of the
// core's exception types (errors.hpp) onto Python exception classes.
#include "bindings.hpp"

#include "nhnet/errors.hpp"

#include <cstring>
#include <exception>

namespace nhnet::python {

Points to_points(const py::handle& array, const char* what) {
  py::array_t<double, py::array::c_style | py::array::forcecast> a;
  try {
    a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
  } catch (const py::error_already_set&) {
    a = {};
  }
  if (!a) {
    PyErr_Clear();
    throw InvalidOptions(std::string(what) + " must be an (N, 3) array of numbers, got " +
                         std::string(py::str(py::type::of(array).attr("__name__"))));
  }
  if (a.ndim() != 2 || a.shape(1) != 3) {
    std::string shape = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i)
      shape += (i ? ", " : "") + std::to_string(a.shape(i));
    shape += a.ndim() == 1 ? ",)" : ")";
    throw InvalidOptions(std::string(what) + " must be an (N, 3) array, got shape " + shape);
  }
  Points p(a.shape(0), 3);
  if (p.size() > 0) std::memcpy(p.data(), a.data(), sizeof(double) * size_t(p.size()));
  return p;
}

py::array_t<bool> to_numpy_mask(const std::vector<uint8_t>& flags) {
  py::array_t<bool> a(py::ssize_t(flags.size()));
  bool* v = a.mutable_data();
  for (size_t i = 0; i < flags.size(); ++i) v[i] = flags[i] != 0;
  return a;
}

// ---------------------------------------------------------------------------------------------
// Progress and cancellation

ProgressBridge::ProgressBridge(py::object user_callback) : user_(std::move(user_callback)) {
  if (user_.is_none()) user_ = py::object();
}

ProgressCallback ProgressBridge::callback() {
  return [this](double fraction, const std::string& stage) { return on_progress(fraction, stage); };
}

bool ProgressBridge::on_progress(double fraction, const std::string& stage) {
  // Called by the core on the calling thread (the one that released the GIL), possibly inside an
  // OpenMP region: nothing may escape from here, every Python error is stored for later.
  if (stopped_) return false;  // a stage that missed the first "stop" meets it at its next report
  const auto now = std::chrono::steady_clock::now();
  // A new stage always gets through: otherwise a short stage's time is charged to the one before.
  const bool same_stage = stage == last_stage_;
  if (fraction < 1.0 && same_stage && now - last_ < std::chrono::milliseconds(50)) return true;
  last_ = now;
  if (!same_stage) last_stage_ = stage;
  py::gil_scoped_acquire gil;
  bool go_on = true;
  if (PyErr_CheckSignals() != 0) {  // Ctrl-C: Python's handler raised KeyboardInterrupt
    go_on = false;
  } else if (user_) {
    PyObject* r = PyObject_CallFunction(user_.ptr(), "ds", fraction, stage.c_str());
    if (!r) {
      go_on = false;  // the callback raised
    } else {
      const int truth = r == Py_None ? 1 : PyObject_IsTrue(r);
      Py_DECREF(r);
      go_on = truth > 0;
    }
  }
  if (PyErr_Occurred()) {
    PyObject *type = nullptr, *value = nullptr, *trace = nullptr;
    PyErr_Fetch(&type, &value, &trace);
    type_ = py::reinterpret_steal<py::object>(type);
    value_ = py::reinterpret_steal<py::object>(value);
    trace_ = py::reinterpret_steal<py::object>(trace);
    has_error_ = true;
  }
  stopped_ = !go_on;
  return go_on;
}

void ProgressBridge::rethrow_if_python_error() {
  if (!has_error_) return;
  has_error_ = false;
  PyErr_Restore(type_.release().ptr(), value_.release().ptr(), trace_.release().ptr());
  throw py::error_already_set();
}

// ---------------------------------------------------------------------------------------------
// Exceptions

namespace {

PyObject* new_error(py::module_& m, const char* name, const char* doc, py::tuple bases) {
  const std::string qualified = std::string("nhnet.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (!type) throw py::error_already_set();
  m.add_object(name, py::reinterpret_borrow<py::object>(type));
  return type;  // the module keeps a reference for the process lifetime
}

}  // namespace

void register_errors(py::module_& m) {
  static PyObject* error = nullptr;
  static PyObject* invalid_options = nullptr;
  static PyObject* input_error = nullptr;
  static PyObject* unprocessable = nullptr;
  static PyObject* output_error = nullptr;
  static PyObject* cancelled = nullptr;

  PyObject* exc = PyExc_Exception;
  error = new_error(m, "Error", "Base class of every error raised by nhnet.",
                    py::make_tuple(py::handle(exc)));
  py::handle base(error), value_error(PyExc_ValueError), os_error(PyExc_OSError);
  invalid_options = new_error(m, "InvalidOptions",
                              "A parameter is out of range or options conflict (a ValueError).",
                              py::make_tuple(base, value_error));
  input_error = new_error(m, "InputError",
                          "An input file cannot be read or is malformed; the message names the "
                          "file and the problem (a ValueError and an OSError).",
                          py::make_tuple(base, value_error, os_error));
  unprocessable = new_error(m, "UnprocessableInput",
                            "The input is well formed but cannot be processed, e.g. fewer than "
                            "3 finite points (a ValueError).",
                            py::make_tuple(base, value_error));
  output_error = new_error(m, "OutputError",
                           "An output file cannot be written; the message names the file and "
                           "the reason (an OSError).",
                           py::make_tuple(base, os_error));
  cancelled =
      new_error(m, "Cancelled", "The progress callback returned False; the work was abandoned.",
                py::make_tuple(base));

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InvalidOptions& e) {
      PyErr_SetString(invalid_options, e.what());
    } catch (const InputError& e) {
      PyErr_SetString(input_error, e.what());
    } catch (const UnprocessableInput& e) {
      PyErr_SetString(unprocessable, e.what());
    } catch (const OutputError& e) {
      PyErr_SetString(output_error, e.what());
    } catch (const Cancelled& e) {
      PyErr_SetString(cancelled, e.what());
    }
  });
}

}  // namespace nhnet::python
