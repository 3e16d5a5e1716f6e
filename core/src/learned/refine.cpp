// NH-Net refinement of the MFPS normals (paper Sec. 5): descriptors (descriptors.hpp), the
// trained model (nhnet_model.hpp), then each frame normal back to world coordinates, R^T n;
// block by block so memory stays bounded.
#include "nhnet/learned/nhnet_model.hpp"

#include "nhnet/errors.hpp"

#include <algorithm>
#include <limits>

namespace nhnet {

std::shared_ptr<const NhNetModel> model_for(const EstimateOptions& options) {
  if (options.loaded_model) return options.loaded_model;
  return std::make_shared<const NhNetModel>(
      options.model.empty() ? default_model_path() : options.model, options.device,
      options.run.threads);
}

EstimateResult estimate_nhnet(const Points& points, const EstimateOptions& options) {
  if (options.nhnet_batch < 1) throw InvalidOptions("nhnet batch must be >= 1");
  // Load first: a missing or mismatched model fails before the long geometry stage.
  const std::shared_ptr<const NhNetModel> loaded = model_for(options);
  const NhNetModel& model = *loaded;
  DescriptorOptions dopt;
  dopt.estimate = options;
  dopt.estimate.method = Method::Mfps;
  ProgressCallback cb = options.run.progress;
  if (cb) dopt.estimate.run.progress = [cb](double f, const std::string& s) { return cb(0.7 * f, s); };
  DescriptorInput in = prepare_descriptors(points, dopt);
  EstimateResult res = std::move(in.geometry);
  res.device_used = model.device();
  res.descriptor_k = in.k;
  // Blocks of points: descriptors, model, back to world coordinates. Memory stays bounded by the
  // block (D floats per point) on top of the neighbour table the geometry stage needs anyway.
  const Eigen::Index m = Eigen::Index(in.rows.size());
  const Eigen::Index block = options.nhnet_batch;
  int64_t kept = 0;
  RunContext run;
  run.threads = options.run.threads;
  for (Eigen::Index b = 0; b < m; b += block) {
    const Eigen::Index len = std::min(block, m - b);
    // The block's stages (descriptor stages, "nhnet") reach the caller's callback by name, so
    // a caller can time descriptors and network apart (the scaling benchmark does).
    if (cb)
      run.progress = [cb, b, len, m](double f, const std::string& s) {
        return cb(0.7 + 0.3 * (double(b) + f * double(len)) / double(m), s);
      };
    const IndexMatrix knn = in.knn.middleRows(b, len);
    DescriptorMatrix features;
    Rotations rot;
    compute_descriptors(in.points, in.normals, knn, in.k, dopt, features, rot, run, b);
    const auto local = model.infer(features, options.nhnet_batch, run);
    for (Eigen::Index r = 0; r < len; ++r) {
      Eigen::Matrix3d rm;
      for (int c = 0; c < 9; ++c) rm(c / 3, c % 3) = rot(r, c);
      const Eigen::Vector3d w = rm.transpose() * local.row(r).transpose().cast<double>();
      if (w.allFinite() && w.norm() > 0.5) {
        res.normals.row(in.rows[size_t(b + r)]) = w.normalized().transpose();
      } else {
        ++kept;  // descriptor or model failed: the MFPS normal stays
      }
    }
    if (cb && !cb(0.7 + 0.3 * double(b + len) / double(m), "nhnet")) throw Cancelled();
  }
  if (kept > 0)
    res.warnings.push_back(std::to_string(kept) +
                           " points kept their MFPS normal (no descriptor or model output)");
  return res;
}

}  // namespace nhnet
