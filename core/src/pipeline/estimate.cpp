// The estimation pipeline (paper Sec. 3-4): finite-point filtering, one kd-tree, noise-driven
// scale choice, PCA for smooth points and MFPS near sharp features.
#include "nhnet/pipeline/estimate.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/bandwidth.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/geometry/mfps.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/geometry/scales.hpp"
#include "neighbors/dedupe.hpp"
#include "util/stats.hpp"
#include "pipeline/tiling.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet {

Method method_from_string(const std::string& name) {
  if (name == "pca") return Method::Pca;
  if (name == "mfps") return Method::Mfps;
  if (name == "nhnet") return Method::NhNet;
  throw InvalidOptions("unknown method '" + name + "' (expected pca, mfps or nhnet)");
}

const char* to_string(Method method) {
  switch (method) {
    case Method::Pca: return "pca";
    case Method::Mfps: return "mfps";
    case Method::NhNet: return "nhnet";
  }
  return "?";
}

}  // namespace nhnet

namespace nhnet {

namespace detail {

// Recentres `pts` (finite) in double and scales it by powers of two so every coordinate lies in
// [-2, 2): far-from-origin scans (UTM-scale 1e6 offsets) keep their precision in the float
// kd-tree, coordinates near 1e31 or 1e-300 neither overflow float squared distances nor fall
// under the absolute floors of the plane fits. Power-of-two factors are exact, so the normals
// are those of the same cloud at the origin at unit size.
double normalise(Points& pts) {
  double unit = 1.0;
  // First bring the magnitudes near 1 so that the mean cannot overflow, then recentre, then
  // scale the extent (which is much smaller than the magnitudes for far-from-origin clouds).
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) pts.rowwise() -= pts.colwise().mean();
    const double max_abs = pts.cwiseAbs().maxCoeff();
    if (!(max_abs > 0) || !std::isfinite(max_abs)) continue;
    const int e = std::ilogb(max_abs);
    pts *= std::ldexp(1.0, -e);
    unit = std::ldexp(unit, e);
  }
  return unit;
}

Probe probe_noise(const Points& pts, const Neighbors& tree, const RunContext& run,
                  IndexMatrix* table) {
  // PCA residuals of the probe neighbourhoods against the point spacing. Clouds of up to
  // kProbeAllPoints points probe every point, and the probe's table (sorted by distance) then
  // serves any smaller size as its prefix. Larger clouds probe an evenly spaced subset of
  // kProbeAllPoints points (every (m / kProbeAllPoints)-th in the canonical order): the noise
  // quantile and the median spacing of that many points differ from the whole cloud's in the
  // third digit, and the neighbour search then runs once, at the size the stages need, instead
  // of twice (note on issue 10).
  Probe out;
  const Eigen::Index m = pts.rows();
  const int kprobe = int(std::min<Eigen::Index>(kNoiseProbeK, m));
  DistanceMatrix d2;
  Eigen::VectorXd residual;
  if (m <= kProbeAllPoints) {
    IndexMatrix local;
    IndexMatrix& knn = table ? *table : local;
    tree.knn_all(kprobe, knn, &d2, narrow(run, 0.02, 0.12));
    if (kprobe < 4) return out;
    residual = pca_normals(pts, knn, PcaOptions{kprobe}, narrow(run, 0.12, 0.2)).residual_rms;
  } else {
    const size_t count = size_t(kProbeAllPoints);
    std::vector<int64_t> rows(count);
    const double step = double(m) / double(count);  // > 1: distinct rows, first row 0
    for (size_t r = 0; r < count; ++r) rows[r] = std::min<int64_t>(int64_t(m) - 1, int64_t(double(r) * step));
    IndexMatrix probe;
    tree.knn_rows(kprobe, rows, probe, &d2, narrow(run, 0.02, 0.06));
    residual.resize(probe.rows());
    parallel_for(probe.rows(), run.threads, nullptr, [&](int64_t r) {
      Eigen::Vector3d ev;
      fit_plane(pts, &probe(r, 0), kprobe, nullptr, &ev);
      residual[r] = std::sqrt(std::max(0.0, ev[0]));
    });
  }
  return probe_from_rows(d2, residual);
}

Probe probe_from_rows(const DistanceMatrix& d2, const Eigen::VectorXd& residual) {
  Probe out;
  out.noise = estimate_noise(d2, residual);
  std::vector<double> far(size_t(d2.rows()));
  for (Eigen::Index i = 0; i < d2.rows(); ++i) far[size_t(i)] = std::sqrt(double(d2(i, d2.cols() - 1)));
  out.far_radius = quantile(std::move(far), 0.99);
  out.far_k = int(d2.cols());
  return out;
}

Canonical canonical_points(const Points& points, std::vector<std::string>& warnings) {
  Canonical c;
  const Eigen::Index n = points.rows();
  std::vector<int64_t>& finite = c.rows;
  // Finite points only: a non-finite point neither gets a normal nor disturbs its neighbours.
  finite.reserve(size_t(n));
  for (Eigen::Index i = 0; i < n; ++i)
    if (points.row(i).allFinite()) finite.push_back(i);
  const size_t finite_count = finite.size();
  c.finite_count = finite_count;
  if (Eigen::Index(finite_count) < n)
    warnings.push_back(std::to_string(n - Eigen::Index(finite_count)) +
                           " non-finite points skipped (reported as failed)");
  // Exact duplicates: only the first copy of a position takes part (k copies of one point would
  // fill its neighbourhood and leave no plane); every copy gets that copy's normal, so a cloud
  // with duplicated points gets the same normals as the deduplicated cloud. The points are
  // processed in a canonical (sorted) order, which makes the result independent of the input
  // order.
  c.copies = dedupe_exact(points, finite);
  if (finite.size() < 3)
    throw UnprocessableInput(
        "only " + std::to_string(finite.size()) +
        (finite.size() < finite_count ? " distinct" : "") + " finite points" +
        (finite.size() < finite_count ? " (" + std::to_string(finite_count) + " with duplicates)"
                                      : std::string()) +
        "; at least 3 are needed");
  if (finite.size() < finite_count)
    warnings.push_back(std::to_string(finite_count - finite.size()) +
                           " exact duplicate points share the normal of their first copy");
  const Eigen::Index m = Eigen::Index(finite.size());
  Points& pts = c.pts;
  pts.resize(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) pts.row(i) = points.row(finite[size_t(i)]);
  // Work in a normalised frame (see normalise()); `unit` converts lengths back to input units.
  c.unit = normalise(pts);

  return c;
}

void finish_result(EstimateResult& res, const std::vector<int64_t>& copies, size_t finite_count) {
  const Eigen::Index n = res.normals.rows();
  const bool flags = res.candidate.size() == size_t(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int64_t first = copies[size_t(i)];
    if (first >= 0 && first != i) {
      res.normals.row(i) = res.normals.row(first);
      res.valid[size_t(i)] = res.valid[size_t(first)];
      res.curvature[i] = res.curvature[first];
      if (flags) res.candidate[size_t(i)] = res.candidate[size_t(first)];
    }
  }
  res.failed = int64_t(std::count(res.valid.begin(), res.valid.end(), uint8_t(0)));
  const int64_t nonfinite = n - int64_t(finite_count);
  if (res.failed > nonfinite)
    res.warnings.push_back(std::to_string(res.failed - nonfinite) +
                           " points with a degenerate neighbourhood (identical or collinear "
                           "neighbours) got no normal (reported as failed)");
}

void check_options(const EstimateOptions& options) {
  if (options.k < 0 || options.k == 1 || options.k == 2)
    throw InvalidOptions("k must be 0 (auto) or at least 3, got " + std::to_string(options.k));
  for (int s : options.scales)
    if (s < 4) throw InvalidOptions("every scale must be at least 4, got " + std::to_string(s));
  if (options.run.threads < 0) throw InvalidOptions("threads must be >= 0");
  if (options.mfps_samples < 1) throw InvalidOptions("mfps samples must be >= 1");
  if (options.tile_points < 0) throw InvalidOptions("tile points must be >= 0 (0 = no tiles)");
  if (!(options.tile_halo > 0)) throw InvalidOptions("tile halo must be > 0");
  if (options.method == Method::NhNet && options.nhnet_batch < 1)
    throw InvalidOptions("nhnet batch must be >= 1");
}

}  // namespace detail

namespace {

int max_scale(const std::vector<int>& scales) {
  return scales.empty() ? 0 : *std::max_element(scales.begin(), scales.end());
}
}  // namespace

EstimateResult estimate_normals(const Points& points, const EstimateOptions& options) {
  detail::check_options(options);
  if (detail::wants_tiles(points, options)) return detail::estimate_tiled(points, options);
  if (options.method == Method::NhNet) return estimate_nhnet(points, options);
  detail::start_threads(options.run.threads);  // before the big allocations

  EstimateResult res;
  const Eigen::Index n = points.rows();
  res.normals.setConstant(n, 3, std::numeric_limits<double>::quiet_NaN());
  res.valid.assign(size_t(n), 0);
  res.curvature.setConstant(n, std::numeric_limits<double>::quiet_NaN());

  detail::Canonical canon = detail::canonical_points(points, res.warnings);
  const std::vector<int64_t>& finite = canon.rows;
  const std::vector<int64_t>& copies = canon.copies;
  const size_t finite_count = canon.finite_count;
  const Eigen::Index m = canon.pts.rows();
  Points& pts = canon.pts;
  const double unit = canon.unit;

  const RunContext& run = options.run;
  detail::Progress top(run.progress);
  if (run.progress) top.stage("kd-tree", 0, 0.02);
  Neighbors tree(pts);
  top.throw_if_cancelled();

  // Noise probe (probe_noise): skipped when every size is given explicitly or the tiling
  // measured the whole cloud already (known_spacing).
  const bool known = options.known_spacing > 0;
  const bool need_probe =
      !known && (options.k == 0 || (options.method == Method::Mfps && options.scales.empty()));
  IndexMatrix knn;
  if (known) {
    res.noise_ratio = options.known_noise_ratio;
    res.spacing = options.known_spacing / unit;
  } else if (need_probe) {
    const detail::Probe probe = detail::probe_noise(pts, tree, run, &knn);
    res.noise_ratio = probe.noise.ratio;
    res.spacing = probe.noise.spacing;
  }
  const double spacing = res.spacing;  // normalised units, for the stages below
  ScaleChoice choice = choose_scales(res.noise_ratio, m);
  {
    // Fewer points than the automatic sizes want: the sizes are clamped to the cloud (the
    // documented fallback), and the user is told.
    const ScaleChoice wanted = choose_scales(res.noise_ratio, kMaxScale);
    const bool mfps_auto = options.method == Method::Mfps && options.scales.empty();
    if ((options.k == 0 && wanted.k_smooth > choice.k_smooth) ||
        (mfps_auto && max_scale(wanted.scales) > max_scale(choice.scales)))
      res.warnings.push_back("only " + std::to_string(m) + " finite points, fewer than the " +
                             std::to_string(mfps_auto ? max_scale(wanted.scales) : wanted.k_smooth) +
                             " neighbours the automatic scale wants; neighbourhoods clamped to " +
                             std::to_string(m) + " points");
  }
  if (options.k > 0) choice.k_smooth = options.k;
  if (!options.scales.empty()) choice.scales = options.scales;
  if (choice.k_smooth > m) {
    res.warnings.push_back("k=" + std::to_string(choice.k_smooth) + " exceeds the " +
                           std::to_string(m) + " finite points; clamped");
    choice.k_smooth = int(m);
  }
  res.k_used = choice.k_smooth;
  const int kneed =
      options.method == Method::Mfps ? std::max(res.k_used, max_scale(choice.scales)) : res.k_used;
  if (kneed > m && options.method == Method::Mfps)
    res.warnings.push_back("largest scale " + std::to_string(kneed) + " exceeds the " +
                           std::to_string(m) + " finite points; scales clamped");
  // Rows are sorted by distance, so the probe's table serves any smaller size as its prefix.
  const int kdepth = int(std::min<Eigen::Index>(kneed, m));
  if (kdepth > knn.cols()) tree.knn_all(kdepth, knn, nullptr, detail::narrow(run, 0.2, 0.35));
  else if (knn.cols() > kdepth) knn = knn.leftCols(kdepth).eval();  // only what the stages use

  const PcaResult pca = pca_normals(pts, knn, PcaOptions{res.k_used}, detail::narrow(run, 0.35, 0.45));
  Normals out = pca.normals;
  if (options.method == Method::Mfps) {
    FeatureDetectionOptions fo;
    fo.fixed_threshold = options.known_variation_threshold;
    const FeatureDetection fd = detect_feature_candidates(pca.variation, fo);
    res.candidates = fd.count;
    res.candidate.assign(size_t(n), 0);
    for (Eigen::Index i = 0; i < m; ++i) res.candidate[size_t(finite[size_t(i)])] = fd.candidate[size_t(i)];
    BandwidthOptions bo;
    bo.k_patch = res.k_used;
    bo.k_average = kdepth;
    const Eigen::VectorXd bw = residual_bandwidth(pts, knn, spacing, bo, detail::narrow(run, 0.45, 0.55));
    MfpsOptions mo;
    mo.scales = choice.scales;
    for (int& s : mo.scales) s = int(std::min<Eigen::Index>(s, m));
    mo.seed = options.seed;
    mo.samples = options.mfps_samples;
    mo.score_subset = options.mfps_score_subset;
    mo.rescore = options.mfps_rescore;
    mo.refine_iterations = options.mfps_refine_iterations;
    mo.point_sigma_factor = options.mfps_point_sigma_factor;
    mo.posterior_beta = options.mfps_posterior_beta;
    mo.edge_sigma_factor = options.mfps_edge_sigma_factor;
    mo.pca_blend = options.mfps_pca_blend;
    mo.record_blend_features = options.mfps_record_blend;
    const MfpsResult mr = mfps_normals(pts, knn, 2.0 * bw, fd.candidate, pca.normals, mo,
                                       detail::narrow(run, 0.55, 1.0));
    res.scales_used = mo.scales;
    out = mr.normals;
    if (options.mfps_record_blend) {
      const Eigen::Index rows = Eigen::Index(mr.blend_rows.size());
      res.mfps_blend_features = mr.blend_features;
      res.mfps_unblended.resize(rows, 3);
      for (Eigen::Index r = 0; r < rows; ++r) {
        const int64_t i = mr.blend_rows[size_t(r)];
        res.mfps_blend_rows.push_back(finite[size_t(i)]);
        res.mfps_unblended.row(r) = mr.unblended_normals.row(i);
      }
    }
  }

  if (options.method == Method::Mfps && kdepth >= 3) {
    // A candidate whose largest neighbourhood is collinear (or one point) has no plane: MFPS's
    // random planes through it would be arbitrary, so it stays invalid like its PCA normal.
    for (Eigen::Index i = 0; i < m; ++i)
      if (!pca.normals.row(i).allFinite() && out.row(i).allFinite() &&
          !fit_plane(pts, &knn(i, 0), kdepth, nullptr, nullptr).allFinite())
        out.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::RowVector3d nrm = out.row(i);
    if (nrm.allFinite() && nrm.squaredNorm() > 0.5) {
      res.normals.row(finite[size_t(i)]) = nrm.normalized();
      res.valid[size_t(finite[size_t(i)])] = 1;
      res.curvature[finite[size_t(i)]] = pca.variation[i];
    }
  }
  res.spacing = spacing * unit;
  detail::finish_result(res, copies, finite_count);
  if (run.progress) {
    top.stage("done", 1, 1);
    top.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
