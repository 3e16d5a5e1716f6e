// NH-Net refinement of the MFPS normals (paper Sec. 5): descriptors (descriptors.hpp), the
// trained model (nhnet_model.hpp), then each frame normal back to world coordinates, R^T n.
#include "nhnet/nhnet_model.hpp"

#include "nhnet/errors.hpp"

#include <limits>

namespace nhnet {

EstimateResult estimate_nhnet(const Points& points, const EstimateOptions& options) {
  if (options.nhnet_batch < 1) throw InvalidOptions("nhnet batch must be >= 1");
  // Load first: a missing or mismatched model fails before the long geometry stage.
  const NhNetModel model(options.model.empty() ? default_model_path() : options.model,
                         options.device, options.run.threads);
  DescriptorOptions dopt;
  dopt.estimate = options;
  dopt.estimate.method = Method::Mfps;
  RunContext run = options.run;
  if (run.progress) {
    ProgressCallback cb = run.progress;
    dopt.estimate.run.progress = [cb](double f, const std::string& s) { return cb(0.85 * f, s); };
    run.progress = [cb](double f, const std::string& s) { return cb(0.85 + 0.15 * f, s); };
  }
  Descriptors d = describe(points, dopt);
  const auto local = model.infer(d.features, options.nhnet_batch, run);
  EstimateResult res = std::move(d.geometry);
  res.device_used = model.device();
  res.descriptor_k = d.k_used;
  int64_t kept = 0;
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (!res.valid[size_t(i)]) continue;
    Eigen::Matrix3d r;
    for (int c = 0; c < 9; ++c) r(c / 3, c % 3) = d.rotations(i, c);
    const Eigen::Vector3d y = local.row(i).transpose().cast<double>();
    const Eigen::Vector3d w = r.transpose() * y;
    if (w.allFinite() && w.norm() > 0.5) {
      res.normals.row(i) = w.normalized().transpose();
    } else {
      ++kept;  // descriptor or model failed: the MFPS normal stays
    }
  }
  if (kept > 0)
    res.warnings.push_back(std::to_string(kept) +
                           " points kept their MFPS normal (no descriptor or model output)");
  return res;
}

}  // namespace nhnet
