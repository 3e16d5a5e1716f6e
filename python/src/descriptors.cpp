// Bindings of the NH-Net descriptor (descriptors.hpp): nhnet.descriptors() is the one call the
// training package uses, so training sees exactly the descriptors that inference computes.
#include "bindings.hpp"

#include "nhnet/pipeline/describe.hpp"

#include <pybind11/stl.h>

#include <cstring>

namespace nhnet::python {

namespace {
/// A row-major Eigen matrix of any scalar type as a new 2-D numpy array (copy).
template <class Matrix>
py::array_t<typename Matrix::Scalar> matrix_to_numpy(const Matrix& m) {
  py::array_t<typename Matrix::Scalar> a({py::ssize_t(m.rows()), py::ssize_t(m.cols())});
  if (m.size() > 0)
    std::memcpy(a.mutable_data(), m.data(), sizeof(typename Matrix::Scalar) * size_t(m.size()));
  return a;
}
}  // namespace

void register_descriptors(py::module_& m) {
  m.attr("DESCRIPTOR_VERSION") = kDescriptorVersion;
  m.attr("DESCRIPTOR_SIZE") = descriptor_size();
  m.attr("HEIGHT_NORMALISATION") = kHeightNormalisation;
  m.def(
      "descriptors",
      [](const py::handle& points, int threads, uint64_t seed, const py::object& progress,
         int version) {
        DescribeOptions opt;
        opt.descriptor = descriptor_options(version);
        opt.estimate.run.threads = threads;
        opt.estimate.mfps.seed = seed;
        const Points pts = to_points(points, "points");
        Descriptors d = run_released(progress, [&](ProgressCallback cb) {
          opt.estimate.run.progress = std::move(cb);
          return describe(pts, opt);
        });
        py::array_t<bool> valid(py::ssize_t(d.geometry.valid.size()));
        for (size_t i = 0; i < d.geometry.valid.size(); ++i)
          valid.mutable_data()[i] = d.geometry.valid[i] != 0;
        py::array_t<double> rot = matrix_to_numpy(d.rotations);
        py::dict out;
        out["features"] = matrix_to_numpy(d.features);
        out["normals"] = to_numpy(d.geometry.normals);
        out["rotations"] =
            rot.reshape({py::ssize_t(d.rotations.rows()), py::ssize_t(3), py::ssize_t(3)});
        out["valid"] = valid;
        out["k_used"] = d.k_used;
        out["scales_used"] = d.geometry.scales_used;
        out["spacing"] = d.geometry.spacing;
        out["noise_ratio"] = d.geometry.noise_ratio;
        return out;
      },
      R"(descriptors(points, threads=0, seed=1, progress=None, version=DESCRIPTOR_VERSION) -> dict

The NH-Net descriptor of every point (paper Sec. 5.1), computed by the core exactly as
`nhnet-cli estimate --method nhnet` does: MFPS normals, 9 bilateral-filtered normals rotated into
the point's canonical frame, and their 9 height maps of 7 x 7.

Returns a dict: 'features' (N, DESCRIPTOR_SIZE) float32 (NaN rows where invalid), 'normals'
(N, 3) float64 MFPS normals, 'rotations' (N, 3, 3) float64 (R @ n maps world to the frame),
'valid' (N,) bool, 'k_used' (descriptor neighbourhood), 'scales_used', 'spacing',
'noise_ratio'. threads / seed / progress as in nhnet.estimate(). version: the descriptor
version (1 .. DESCRIPTOR_VERSION) a model was trained on; 2 caps the neighbours it sees.)",
      py::arg("points"), py::kw_only(), py::arg("threads") = EstimateOptions{}.run.threads,
      py::arg("seed") = EstimateOptions{}.mfps.seed, py::arg("progress") = py::none(),
      py::arg("version") = kDescriptorVersion);
}

}  // namespace nhnet::python
