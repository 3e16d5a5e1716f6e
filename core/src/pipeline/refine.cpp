// NH-Net refinement of the MFPS normals (paper Sec. 5): the geometry stage's MFPS normals, their
// descriptors (learned/descriptors.hpp), the trained model (learned/nhnet_model.hpp), then each
// frame normal back to world coordinates, R^T n; block by block so memory stays bounded. Last,
// not the paper's, the candidate mix (learned/candidate_mix.hpp) and the learned weighted jet fit
// (learned/learned_fit.hpp).
#include "nhnet/errors.hpp"
#include "nhnet/learned/candidate_mix.hpp"
#include "nhnet/learned/learned_fit.hpp"
#include "pipeline/estimator.hpp"
#include "pipeline/row_order.hpp"
#include "util/parallel.hpp"
#include "util/shared_setting.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace nhnet {

std::shared_ptr<const NhNetModel> model_for(const ModelOptions& options, int threads) {
  if (options.loaded) return options.loaded;
  return std::make_shared<const NhNetModel>(
      options.path.empty() ? default_model_path() : options.path, options.device, threads,
      options.precision);
}

namespace {

/// While held, glibc's malloc serves every size from its heap and keeps freed memory there: the
/// network's per-batch activations (about 230 MB at 4096 points) are otherwise mmap'ed, faulted
/// in and unmapped anew for every batch, which cost as much CPU time as the convolutions
/// (docs/design/decisions.md#nh-net-activations-kept-in-the-heap). When the last holder goes,
/// glibc's defaults come back (mmap above the threshold, trim above 128 KiB) and the free heap is
/// returned to the system; estimates running at once in one process share the settings (the
/// first applies them, the last restores them). Other C libraries: no effect.
detail::SharedSetting& heap_for_batches() {
  static detail::SharedSetting setting(
      [] {
#if defined(__GLIBC__)
        mallopt(M_MMAP_MAX, 0);
        mallopt(M_TRIM_THRESHOLD, std::numeric_limits<int>::max());
#endif
      },
      [] {
#if defined(__GLIBC__)
        mallopt(M_MMAP_MAX, 65536);             // glibc's DEFAULT_MMAP_MAX
        mallopt(M_TRIM_THRESHOLD, 128 * 1024);  // glibc's DEFAULT_TRIM_THRESHOLD
        malloc_trim(0);
#endif
      });
  return setting;
}

/// The progress of block b (len of m points) within the last 30 % of the run.
ProgressCallback block_progress(const ProgressCallback& cb, Eigen::Index b, Eigen::Index len,
                                Eigen::Index m) {
  if (!cb) return {};
  return [cb, b, len, m](double f, const std::string& s) {
    return cb(0.7 + 0.3 * (double(b) + f * double(len)) / double(m), s);
  };
}

/// One block of described points through the model; each frame normal back to world
/// coordinates (R^T n) into res. Returns how many points kept their MFPS normal.
int64_t refine_block(const DescriptorInput& in, Eigen::Index b, Eigen::Index len,
                     const NhNetModel& model, const EstimateOptions& options, const RunContext& run,
                     EstimateResult& res) {
  const IndexMatrix knn = in.knn.middleRows(b, len);
  DescriptorMatrix features;
  Rotations rot;
  compute_descriptors(in.points, in.normals, knn, in.k,
                      descriptor_options(model.descriptor_version()), features, rot, run, b);
  const auto local = model.infer(features, options.model.batch, run);
  int64_t kept = 0;
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
  return kept;
}

/// The points NH-Net refines when not every point (ModelOptions::refine): those whose MFPS normal
/// is not their PCA normal (MFPS moved it near a feature). Elsewhere the mix chooses among PCA and
/// its geometric candidates (jet, half-scale PCA, radial) at a fraction of the network's cost.
std::vector<uint8_t> moved_by_mfps(const EstimateResult& geometry,
                                   const detail::GeometrySide& side) {
  std::vector<uint8_t> moved(geometry.valid.size(), 0);
  for (Eigen::Index i = 0; i < Eigen::Index(moved.size()); ++i)
    moved[size_t(i)] = geometry.valid[size_t(i)] &&
                       (geometry.normals.row(i).array() != side.pca.row(i).array()).any();
  return moved;
}

/// The stride of ModelOptions::network_stride for a cloud whose neighbourhoods have k points.
int network_stride(const ModelOptions& model, int k) {
  return model.network_stride > 0 ? model.network_stride : std::clamp(k / 16, 1, 8);
}

/// The nearest row of `side.knn` (after self) that `described` marks, or -1.
int32_t nearest_described(const detail::GeometrySide& side, const std::vector<uint8_t>& described,
                          Eigen::Index i) {
  for (Eigen::Index j = 1; j < side.knn.cols(); ++j)
    if (described[size_t(side.knn(i, j))]) return side.knn(i, j);
  return -1;
}

/// The points the network describes on a cloud where it runs everywhere but its stride
/// (ModelOptions::network_stride) is over 1: the strided rows (the rows run along a Morton
/// curve), the moved ones, and those whose PCA normal (over k_used neighbours: smooth, it
/// follows the surface's bend) is over the gate off that of their nearest strided row, or that
/// have none among their kMixNeighbours. Empty: every point.
std::vector<uint8_t> strided_points(const EstimateResult& geometry,
                                    const detail::GeometrySide& side, const ModelOptions& model,
                                    int threads) {
  const int stride = network_stride(model, geometry.k_used);
  if (stride <= 1 || side.knn.rows() != geometry.normals.rows()) return {};
  std::vector<uint8_t> strided(geometry.valid.size(), 0);
  for (size_t i = 0; i < strided.size(); i += size_t(stride)) strided[i] = geometry.valid[i];
  std::vector<uint8_t> described = moved_by_mfps(geometry, side);
  const double gate = std::cos(model.network_gate_deg * M_PI / 180);
  detail::parallel_for(Eigen::Index(strided.size()), threads, nullptr, [&](int64_t i) {
    if (!geometry.valid[size_t(i)] || strided[size_t(i)]) {
      described[size_t(i)] |= strided[size_t(i)];
      return;
    }
    const int32_t c = nearest_described(side, strided, i);
    if (c < 0 || !(std::abs(side.pca.row(i).dot(side.pca.row(c))) >= gate))
      described[size_t(i)] = 1;
  });
  return described;
}

/// The network normal of every valid point the network did not describe: the mean of its
/// described neighbours' among its kMixNeighbours, each turned to the nearest one's side (around
/// the point the surface's bend cancels out, where the nearest one's alone is tilted by it); its
/// MFPS normal stays when none is described.
void share_network_normals(const detail::GeometrySide& side, const std::vector<uint8_t>& described,
                           int threads, EstimateResult& res) {
  detail::parallel_for(res.normals.rows(), threads, nullptr, [&](int64_t i) {
    if (!res.valid[size_t(i)] || described[size_t(i)]) return;
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero(), first = sum;
    for (Eigen::Index j = 1; j < side.knn.cols(); ++j) {
      const int32_t c = side.knn(i, j);
      if (!described[size_t(c)]) continue;
      const Eigen::RowVector3d n = res.normals.row(c);
      if (first.isZero()) first = n;
      sum += n.dot(first) < 0 ? -n : n;
    }
    if (sum.allFinite() && sum.norm() > 0) res.normals.row(i) = sum.normalized();
  });
}

/// The candidate mix (candidate_mix.hpp) of every point with a normal: network normals in `res`
/// (MFPS's where the network did not run), MFPS normals in `mfps`, the rest in `side`.
void mix_stage(const Normals& mfps, const detail::GeometrySide& side, bool everywhere,
               const RunContext& run, EstimateResult& res) {
  if (side.knn.cols() < kMixNeighbours) return;  // too small a cloud: the network's normals stay
  CandidateMixInput mi;
  mi.net = &res.normals;
  mi.mfps = &mfps;
  mi.pca = &side.pca;
  mi.jet = &side.jet;
  mi.half = &side.half;
  mi.half_variation = &side.half_variation;
  mi.radial = &side.radial;
  mi.radial_half = &side.radial_half;
  mi.blend_weight = &side.blend_weight;
  mi.variation = &res.curvature;
  mi.knn = &side.knn;
  mi.noise_ratio = res.noise_ratio;
  mi.network_everywhere = everywhere;
  const Normals mixed = mix_candidates(mi, run);
  for (Eigen::Index i = 0; i < mixed.rows(); ++i)
    if (res.valid[size_t(i)]) res.normals.row(i) = mixed.row(i);
}

/// The learned weighted jet fit (learned_fit.hpp) of every point with a normal, on the mixed
/// normals in `res`; nothing when the cloud was too small for its members.
void fit_stage(const Points& points, const detail::GeometrySide& side, const RunContext& run,
               EstimateResult& res) {
  if (side.members.rows() != res.normals.rows()) return;
  LearnedFitInput fi;
  fi.points = &points;
  fi.normals = &res.normals;
  fi.members = &side.members;
  fi.noise_ratio = res.noise_ratio;
  const Normals fitted = learned_fit(fi, run);
  for (Eigen::Index i = 0; i < fitted.rows(); ++i)
    if (res.valid[size_t(i)] && fitted.row(i).allFinite()) res.normals.row(i) = fitted.row(i);
}

}  // namespace

namespace detail {
namespace {

/// estimate_nhnet on rows in any order (a shuffled cloud: slower, same normals).
EstimateResult estimate_nhnet_rows(const Points& points, const EstimateOptions& options,
                                   const TileOverrides& overrides) {
  // Options are checked (check_options: batch >= 1). Load first: a missing or mismatched model
  // fails before the long geometry stage.
  const std::shared_ptr<const NhNetModel> loaded = model_for(options.model, options.run.threads);
  const ProgressCallback cb = options.run.progress;
  // The geometry stage and the descriptor neighbourhoods take the first 70 % of the progress.
  EstimateOptions eo = options;
  if (cb) eo.run.progress = [cb](double f, const std::string& s) { return cb(0.7 * f, s); };
  // The geometry stage as the model was trained on it (describe.hpp): MFPS without the blend.
  // One neighbour search for both: the geometry stage's table reaches the descriptors' k.
  GeometrySide side;
  SharedTable table{descriptor_options(loaded->descriptor_version()), {}, {}};
  EstimateResult geometry =
      estimate_geometry(points, geometry_options(eo, DescribeOptions{}.mfps_pca_blend), overrides,
                        options.model.candidate_mix ? &side : nullptr, &table);
  // The mix needs the MFPS normals before the network overwrites them; without it, no copy.
  const Normals mfps = options.model.candidate_mix ? geometry.normals : Normals();
  const bool only_moved =
      options.model.candidate_mix && !network_everywhere(options.model, geometry.noise_ratio);
  const std::vector<uint8_t> described =
      !options.model.candidate_mix ? std::vector<uint8_t>()
      : only_moved                 ? moved_by_mfps(geometry, side)
                                   : strided_points(geometry, side, options.model, eo.run.threads);
  DescriptorInput in =
      descriptor_input(points, std::move(geometry), table.descriptor, narrow(eo.run, 0.9, 1),
                       described.empty() ? nullptr : &described, &table);
  EstimateResult res = std::move(in.geometry);
  res.device_used = loaded->device();
  res.precision_used = loaded->precision();
  res.descriptor_k = in.k;
  // Blocks of points: memory stays bounded by the block (D floats per point) on top of the
  // neighbour table the geometry stage needs anyway. The block's stages (descriptor stages,
  // "nhnet") reach the caller's callback by name, so a caller can time them apart.
  const Eigen::Index m = in.described, block = options.model.batch;
  int64_t kept = 0;
  RunContext run;
  run.threads = options.run.threads;
  const detail::SharedSetting::Hold heap(heap_for_batches());
  for (Eigen::Index b = 0; b < m; b += block) {
    const Eigen::Index len = std::min(block, m - b);
    run.progress = block_progress(cb, b, len, m);
    kept += refine_block(in, b, len, *loaded, options, run, res);
    if (cb && !cb(0.7 + 0.3 * double(b + len) / double(m), "nhnet")) throw Cancelled();
  }
  if (!only_moved && !described.empty())
    share_network_normals(side, described, options.run.threads, res);
  if (options.model.candidate_mix) {
    // A short stage after the last block: it reports at 100 % and can still be cancelled.
    run.progress = cb ? ProgressCallback([cb](double, const std::string& s) { return cb(1, s); })
                      : ProgressCallback();
    mix_stage(mfps, side, !only_moved, run, res);
    if (options.model.learned_fit) fit_stage(points, side, run, res);
  }
  if (kept > 0)
    res.warnings.push_back(std::to_string(kept) +
                           " points kept their MFPS normal (no descriptor or model output)");
  return res;
}

}  // namespace

EstimateResult estimate_nhnet(const Points& points, const EstimateOptions& options,
                              const TileOverrides& overrides) {
  // The rows along a Morton curve (row_order.hpp): the same normals, read from nearby memory.
  const RowOrder order = row_order(points);
  const Points permuted = permute_rows(points, order);
  if (overrides.prepared && overrides.prepared->source == points.data())
    permute_prepared(*overrides.prepared, order, permuted);  // then not built again
  EstimateResult res = estimate_nhnet_rows(permuted, options, overrides);
  restore_rows(res, order);
  return res;
}

}  // namespace detail
}  // namespace nhnet
