// The estimation pipeline (paper Sec. 3-4): finite-point filtering, one kd-tree, noise-driven
// scale choice, PCA for smooth points and MFPS near sharp features.
#include "nhnet/pipeline/estimate.hpp"

#include "neighbors/dedupe.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/bandwidth.hpp"
#include "nhnet/geometry/feature_detection.hpp"
#include "nhnet/geometry/jet.hpp"
#include "nhnet/geometry/mfps.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/geometry/radial.hpp"
#include "nhnet/geometry/scales.hpp"
#include "nhnet/learned/candidate_mix.hpp"
#include "nhnet/learned/confidence.hpp"
#include "nhnet/learned/learned_fit.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "pipeline/cell_means.hpp"
#include "pipeline/estimator.hpp"
#include "util/parallel.hpp"
#include "util/spread.hpp"
#include "util/stats.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <stdexcept>
#include <system_error>

namespace nhnet {

namespace {

// One table per option enum: the name each value has on the command line and in Python.
template <typename E>
struct Named {
  E value;
  const char* name;
};

constexpr Named<Method> kMethodNames[] = {
    {Method::Pca, "pca"}, {Method::Mfps, "mfps"}, {Method::NhNet, "nhnet"}};
constexpr Named<Refine> kRefineNames[] = {
    {Refine::All, "all"}, {Refine::Moved, "moved"}, {Refine::Auto, "auto"}};

// The entry called `name`, or nullptr.
template <typename E, std::size_t N>
const Named<E>* find_named(const Named<E> (&table)[N], const std::string& name) {
  for (const auto& entry : table)
    if (name == entry.name) return &entry;
  return nullptr;
}

template <typename E, std::size_t N>
const char* name_of(const Named<E> (&table)[N], E value) {
  for (const auto& entry : table)
    if (entry.value == value) return entry.name;
  return "?";
}

}  // namespace

Method method_from_string(const std::string& name) {
  if (const auto* entry = find_named(kMethodNames, name)) return entry->value;
  throw InvalidOptions("unknown method '" + name + "' (expected pca, mfps or nhnet)");
}

Refine refine_from_string(const std::string& name) {
  if (const auto* entry = find_named(kRefineNames, name)) return entry->value;
  throw InvalidOptions("refine must be 'all', 'moved' or 'auto', got '" + name + "'");
}

const char* to_string(Refine refine) { return name_of(kRefineNames, refine); }

double cell_means_from_string(const std::string& text) {
  if (text == "auto") return CellMeanOptions{}.noise_ratio;
  if (text == "off") return 0;
  double ratio = std::nan("");
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), last, ratio);
  if (text.empty() || ec != std::errc() || ptr != last || !std::isfinite(ratio) || !(ratio > 0)) {
    std::string shown = text.substr(0, 40);  // one line, whatever was given
    for (char& c : shown)
      if (static_cast<unsigned char>(c) < 0x20) c = ' ';
    throw InvalidOptions("must be auto, off or a noise ratio > 0, got '" + shown + "'");
  }
  return ratio;
}

const char* to_string(Method method) { return name_of(kMethodNames, method); }

bool network_everywhere(const ModelOptions& options, double noise_ratio) {
  if (options.refine == Refine::Auto) return noise_ratio >= options.auto_noise_ratio;
  return options.refine == Refine::All;
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
  // of twice (docs/design/decisions.md#noise-probe-on-a-subset).
  Probe out;
  const Eigen::Index m = pts.rows();
  const int kprobe = int(std::min<Eigen::Index>(kNoiseProbeK, m));
  DistanceMatrix d2;
  IndexMatrix local;
  IndexMatrix& knn = table && m <= kProbeAllPoints ? *table : local;
  if (m <= kProbeAllPoints) {
    tree.knn_all(kprobe, knn, &d2, narrow(run, 0.02, 0.12));
  } else {
    const size_t count = size_t(kProbeAllPoints);
    std::vector<int64_t> rows(count);
    const double step = double(m) / double(count);  // > 1: distinct rows, first row 0
    for (size_t r = 0; r < count; ++r)
      rows[r] = std::min<int64_t>(int64_t(m) - 1, int64_t(double(r) * step));
    tree.knn_rows(kprobe, rows, knn, &d2, narrow(run, 0.02, 0.06));
  }
  if (kprobe < 4) return out;
  ProbeResiduals residual(knn.rows(), 2);
  const RunContext fits = narrow(run, 0.12, 0.2);  // reported and cancellable, as the search
  Progress progress(fits.progress);
  if (fits.progress) progress.stage("noise probe", 0, 1);
  parallel_for(knn.rows(), run.threads, fits.progress ? &progress : nullptr, [&](int64_t r) {
    residual.row(r) = probe_residuals(pts, &knn(r, 0), kprobe).transpose();
  });
  return probe_from_rows(d2, residual);
}

Probe probe_from_rows(const DistanceMatrix& d2, const ProbeResiduals& residual) {
  Probe out;
  out.noise = estimate_noise(d2, residual);
  std::vector<double> far(size_t(d2.rows()));
  for (Eigen::Index i = 0; i < d2.rows(); ++i)
    far[size_t(i)] = std::sqrt(double(d2(i, d2.cols() - 1)));
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
    throw UnprocessableInput("only " + std::to_string(finite.size()) +
                             (finite.size() < finite_count ? " distinct" : "") + " finite points" +
                             (finite.size() < finite_count
                                  ? " (" + std::to_string(finite_count) + " with duplicates)"
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

void index_points(const Points& points, Prepared& prepared) {
  prepared.source = points.data();
  prepared.canon = canonical_points(points, prepared.warnings);
  prepared.tree = std::make_unique<Neighbors>(prepared.canon.pts);
}

void prepare_points(const Points& points, Prepared& prepared, const RunContext& run) {
  index_points(points, prepared);
  prepared.probe = probe_noise(prepared.canon.pts, *prepared.tree, run, nullptr);
  prepared.probed = true;
}

namespace {

/// Calls copy(i, first) for every row i of `copies` (Canonical::copies) that duplicates an
/// earlier row `first`: what each output does so that exact copies share their first's result.
template <class Copy>
void copy_to_duplicates(const std::vector<int64_t>& copies, Copy&& copy) {
  for (size_t i = 0; i < copies.size(); ++i) {
    const int64_t first = copies[i];
    if (first >= 0 && first != int64_t(i)) copy(Eigen::Index(i), Eigen::Index(first));
  }
}

}  // namespace

void finish_result(EstimateResult& res, const std::vector<int64_t>& copies, size_t finite_count) {
  const Eigen::Index n = res.normals.rows();
  const bool flags = res.candidate.size() == size_t(n);
  copy_to_duplicates(copies, [&](Eigen::Index i, Eigen::Index first) {
    res.normals.row(i) = res.normals.row(first);
    res.valid[size_t(i)] = res.valid[size_t(first)];
    res.curvature[i] = res.curvature[first];
    if (res.confidence.size() == n) res.confidence[i] = res.confidence[first];
    if (flags) res.candidate[size_t(i)] = res.candidate[size_t(first)];
  });
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
  for (int s : options.mfps.scales)
    if (s < 4) throw InvalidOptions("every scale must be at least 4, got " + std::to_string(s));
  if (options.run.threads < 0) throw InvalidOptions("threads must be >= 0");
  if (options.mfps.samples < 1) throw InvalidOptions("mfps samples must be >= 1");
  if (options.tiles.points < 0) throw InvalidOptions("tile points must be >= 0 (0 = no tiles)");
  if (!(options.tiles.halo > 0)) throw InvalidOptions("tile halo must be > 0");
  if (!(options.cell_means.noise_ratio >= 0) || !(options.cell_means.edge > 0))
    throw InvalidOptions("cell means need a noise ratio >= 0 (0 = off) and an edge > 0");
  if (options.method == Method::NhNet && options.model.batch < 1)
    throw InvalidOptions("nhnet batch must be >= 1");
  if (options.model.network_stride < 0)
    throw InvalidOptions("nhnet network stride must be >= 0 (0 = automatic, 1 = every point)");
  if (!(options.model.network_gate_deg >= 0 && options.model.network_gate_deg <= 90))
    throw InvalidOptions("nhnet network gate must be between 0 and 90 degrees");
}

}  // namespace detail

namespace {

int max_scale(const std::vector<int>& scales) {
  return scales.empty() ? 0 : *std::max_element(scales.begin(), scales.end());
}

/// The noise level and spacing (normalised units) of the canonical points: the tiling's when it
/// measured them, else the noise probe's when some size is automatic (`knn` then receives the
/// probe's neighbour table), else unknown (0).
void measure_noise(const Points& pts, const Neighbors& tree, double unit,
                   const EstimateOptions& options, const detail::TileOverrides& overrides,
                   IndexMatrix& knn, EstimateResult& res) {
  if (overrides.spacing > 0) {
    res.noise_ratio = overrides.noise_ratio;
    res.spacing = overrides.spacing / unit;
    return;
  }
  const bool need_probe =
      options.k == 0 || (options.method == Method::Mfps && options.mfps.scales.empty());
  if (!need_probe) return;
  const detail::Probe probe = detail::probe_noise(pts, tree, options.run, &knn);
  res.noise_ratio = probe.noise.ratio;
  res.spacing = probe.noise.spacing;
}

/// PCA k and MFPS scales for m points (scales.hpp; the options' k and scales win), clamped to
/// the cloud with a warning when it is smaller than the sizes want; sets res.k_used.
ScaleChoice choose_sizes(const EstimateOptions& options, Eigen::Index m, EstimateResult& res) {
  ScaleChoice choice = choose_scales(res.noise_ratio, m);
  const ScaleChoice wanted = choose_scales(res.noise_ratio, kMaxScale);
  const bool mfps_auto = options.method == Method::Mfps && options.mfps.scales.empty();
  if ((options.k == 0 && wanted.k_smooth > choice.k_smooth) ||
      (mfps_auto && max_scale(wanted.scales) > max_scale(choice.scales)))
    res.warnings.push_back("only " + std::to_string(m) + " finite points, fewer than the " +
                           std::to_string(mfps_auto ? max_scale(wanted.scales) : wanted.k_smooth) +
                           " neighbours the automatic scale wants; neighbourhoods clamped to " +
                           std::to_string(m) + " points");
  if (options.k > 0) choice.k_smooth = options.k;
  if (!options.mfps.scales.empty()) choice.scales = options.mfps.scales;
  if (choice.k_smooth > m) {
    res.warnings.push_back("k=" + std::to_string(choice.k_smooth) + " exceeds the " +
                           std::to_string(m) + " finite points; clamped");
    choice.k_smooth = int(m);
  }
  res.k_used = choice.k_smooth;
  return choice;
}

/// Depth of the shared neighbour table: the largest size a stage uses, at most m (with a
/// warning when MFPS's largest scale is clamped).
int table_depth(const EstimateOptions& options, const ScaleChoice& choice, Eigen::Index m,
                EstimateResult& res) {
  const int kneed =
      options.method == Method::Mfps ? std::max(res.k_used, max_scale(choice.scales)) : res.k_used;
  if (kneed > m && options.method == Method::Mfps)
    res.warnings.push_back("largest scale " + std::to_string(kneed) + " exceeds the " +
                           std::to_string(m) + " finite points; scales clamped");
  return int(std::min<Eigen::Index>(kneed, m));
}

/// The one neighbour table every stage shares, at least `kdepth` deep: the probe's table when it
/// is deep enough (rows are sorted by distance, so it serves any smaller size as its prefix).
void neighbour_table(const Neighbors& tree, int kdepth, const RunContext& run, IndexMatrix& knn) {
  if (kdepth > knn.cols()) tree.knn_all(kdepth, knn, nullptr, detail::narrow(run, 0.2, 0.35));
}

/// Columns of EstimateResult::neighbours this run returns: EstimateOptions::neighbours (at most
/// the m canonical points) when every input row is a distinct finite point, else 0.
int shared_columns(const EstimateOptions& options, const detail::Canonical& canon) {
  if (options.neighbours <= 0 || canon.rows.size() != canon.copies.size()) return 0;
  return int(std::min<Eigen::Index>(options.neighbours, canon.pts.rows()));
}

/// Depth the descriptors need of the shared table (SharedTable): descriptor_input's k
/// (descriptor_k_of_scales), 0 without a table or when the cloud has duplicate or non-finite
/// rows (the descriptors then search their own).
int descriptor_depth(const detail::SharedTable* table, const detail::Canonical& canon,
                     const ScaleChoice& choice) {
  if (!table || canon.rows.size() != canon.copies.size()) return 0;
  return descriptor_k_of_scales(choice.scales, table->descriptor, canon.pts.rows());
}

/// Depth the learned fit needs of the shared table (learned_fit_k), 0 without it or when the
/// cloud has fewer points than that (the mix's normals stay).
int fit_depth(const EstimateOptions& options, const detail::GeometrySide* side, int k,
              Eigen::Index m) {
  if (!side || !options.model.learned_fit || learned_fit_k(k) > m) return 0;
  return learned_fit_k(k);
}

/// The learned fit's members (canonical rows): kFitMembers spread over the first `depth`
/// columns of `knn` (util/spread.hpp); empty when depth is 0.
IndexMatrix fit_members(const IndexMatrix& knn, int depth, int threads) {
  IndexMatrix members;
  if (depth <= 0) return members;
  members.resize(knn.rows(), kFitMembers);
  std::array<Eigen::Index, kFitMembers> rank;
  for (int t = 0; t < kFitMembers; ++t)
    rank[size_t(t)] = detail::spread_rank(t, kFitMembers, depth);
  // Row by row (the tables are row-major: a column at a time strides the whole table 64 times).
  detail::parallel_for(knn.rows(), threads, nullptr, [&](int64_t i) {
    for (int t = 0; t < kFitMembers; ++t) members(i, t) = knn(i, rank[size_t(t)]);
  });
  return members;
}

/// EstimateResult::neighbours: the first `cols` columns of the canonical table as input rows.
void share_neighbours(const IndexMatrix& knn, const detail::Canonical& canon, int cols,
                      const RunContext& run, EstimateResult& res) {
  if (cols <= 0) return;
  const std::vector<int64_t>& rows = canon.rows;
  res.neighbours.resize(Eigen::Index(rows.size()), cols);
  detail::parallel_for(int64_t(rows.size()), run.threads, nullptr, [&](int64_t i) {
    for (int j = 0; j < cols; ++j)
      res.neighbours(rows[size_t(i)], j) = int32_t(rows[size_t(knn(i, j))]);
  });
}

/// What MFPS needs besides the points: the canonical rows and the sizes the pipeline chose.
struct MfpsInput {
  const std::vector<int64_t>& finite;
  const ScaleChoice& choice;
  int kdepth;
  double spacing;  // normalised units
};

/// Paper Sec. 4: candidates near sharp features from the PCA surface variation, the residual
/// bandwidth as the kernel width sigma_j = 2 b, then MFPS (Eq. 1-4) on the candidates; the
/// other points keep their PCA normal. Fills the candidate flags, scales and blend diagnostics.
Normals mfps_stage(const Points& pts, const IndexMatrix& knn, const PcaResult& pca,
                   const MfpsInput& in, const EstimateOptions& options,
                   const detail::TileOverrides& overrides, EstimateResult& res,
                   Eigen::VectorXd* blend_weight) {
  const Eigen::Index m = pts.rows();
  FeatureDetectionOptions fo;
  fo.fixed_threshold = overrides.variation_threshold;
  const FeatureDetection fd = detect_feature_candidates(pca.variation, fo);
  res.candidates = fd.count;
  res.candidate.assign(res.valid.size(), 0);
  for (Eigen::Index i = 0; i < m; ++i)
    res.candidate[size_t(in.finite[size_t(i)])] = fd.candidate[size_t(i)];
  BandwidthOptions bo;
  bo.k_patch = res.k_used;
  bo.k_average = in.kdepth;
  const Eigen::VectorXd bw =
      residual_bandwidth(pts, knn, in.spacing, bo, detail::narrow(options.run, 0.45, 0.55), &pca);
  MfpsOptions mo = options.mfps;
  const bool recorded = mo.record_blend_features;
  mo.keep_blend_weights = mo.keep_blend_weights || blend_weight != nullptr;  // weights, no copies
  mo.scales = in.choice.scales;
  for (int& s : mo.scales) s = int(std::min<Eigen::Index>(s, m));
  const MfpsResult mr = mfps_normals(pts, knn, 2.0 * bw, fd.candidate, pca.normals, mo,
                                     detail::narrow(options.run, 0.55, 1.0));
  res.scales_used = mo.scales;
  if (blend_weight) {
    blend_weight->setZero(m);
    for (size_t t = 0; t < mr.blend_rows.size(); ++t)
      (*blend_weight)[mr.blend_rows[t]] = mr.blend_weights[t];
  }
  if (recorded) {
    const Eigen::Index rows = Eigen::Index(mr.blend_rows.size());
    res.mfps_blend_features = mr.blend_features;
    res.mfps_unblended.resize(rows, 3);
    for (Eigen::Index r = 0; r < rows; ++r) {
      const int64_t i = mr.blend_rows[size_t(r)];
      res.mfps_blend_rows.push_back(in.finite[size_t(i)]);
      res.mfps_unblended.row(r) = mr.unblended_normals.row(i);
    }
  }
  return mr.normals;
}

/// A candidate whose largest neighbourhood is collinear (or one point) has no plane: MFPS's
/// random planes through it would be arbitrary, so it stays invalid like its PCA normal.
void drop_planeless(const Points& pts, const IndexMatrix& knn, int kdepth, const Normals& pca,
                    Normals& out) {
  if (kdepth < 3) return;
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    if (!pca.row(i).allFinite() && out.row(i).allFinite() &&
        !fit_plane(pts, &knn(i, 0), kdepth, nullptr, nullptr).allFinite())
      out.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
}

/// The side outputs of the geometry stage in canonical rows (GeometrySide before scatter_side).
struct CanonicalSide {
  Normals pca, jet, half;
  Eigen::VectorXd half_variation;
  RadialResult radial, radial_half;
  Eigen::VectorXd weight;  // empty without MFPS
  IndexMatrix members;     // empty without the learned fit
};

/// A RadialResult standing in where the cloud is too small for one: all NaN.
RadialResult no_radial(Eigen::Index n) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return {Normals::Constant(n, 3, nan), Eigen::VectorXd::Constant(n, nan),
          Eigen::VectorXd::Constant(n, nan)};
}

/// The candidate mix's geometric candidates (jet, half-scale PCA, radial at both scales) from
/// the shared table `knn`; the radial ones from PCA's planes (`pca` at k, asked for its radial
/// candidates, which move out of it; the half scale's with them).
CanonicalSide side_candidates(const Points& pts, const IndexMatrix& knn, PcaResult& pca, int k,
                              const RunContext& run) {
  if (pca.radial.normals.rows() != pts.rows())
    throw std::logic_error("side_candidates: PCA was run without PcaOptions::radial");
  CanonicalSide cs;
  cs.pca = pca.normals;
  const RunContext last = detail::narrow(run, 1, 1);  // two short passes, still cancellable
  if (k < 6 || knn.cols() < 6) {                      // a tiny cloud: PCA stands in for all
    cs.jet = cs.half = pca.normals;
    cs.half_variation = pca.variation;
    cs.radial = cs.radial_half = no_radial(pts.rows());
    return cs;
  }
  cs.jet = jet_normals(pts, knn, pca.normals, JetOptions{k}, last);
  PcaResult half = pca_normals(pts, knn, PcaOptions{mix_half_k(k), false, true}, last);
  cs.half = std::move(half.normals);
  cs.half_variation = std::move(half.variation);
  cs.radial = std::move(pca.radial);
  cs.radial_half = std::move(half.radial);
  return cs;
}

/// Row `from` of a radial result into row `to` of another.
void put_radial(RadialResult& out, Eigen::Index to, const RadialResult& in, Eigen::Index from) {
  out.normals.row(to) = in.normals.row(from);
  out.offset[to] = in.offset[from];
  out.elongation[to] = in.elongation[from];
}

/// Sizes the side outputs for n input rows, without filling them (scatter_side writes each row).
void size_side(Eigen::Index n, Eigen::Index kn, bool members, detail::GeometrySide& side) {
  for (Normals* out : {&side.pca, &side.jet, &side.half}) out->resize(n, 3);
  side.blend_weight.resize(n);
  side.half_variation.resize(n);
  for (RadialResult* r : {&side.radial, &side.radial_half}) {
    r->normals.resize(n, 3);
    r->offset.resize(n);
    r->elongation.resize(n);
  }
  side.knn.resize(n, kn);
  side.members.resize(members ? n : 0, kFitMembers);
}

/// Input row `row` of the side outputs for a point without a normal: NaN candidates, no blend,
/// itself as every neighbour and member.
void blank_side_row(Eigen::Index row, detail::GeometrySide& side) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (Normals* out : {&side.pca, &side.jet, &side.half}) out->row(row).setConstant(nan);
  side.blend_weight[row] = 0;
  side.half_variation[row] = nan;
  for (RadialResult* r : {&side.radial, &side.radial_half}) {
    r->normals.row(row).setConstant(nan);
    r->offset[row] = r->elongation[row] = nan;
  }
  side.knn.row(row).setConstant(int32_t(row));
  if (side.members.rows() > 0) side.members.row(row).setConstant(int32_t(row));
}

/// The side outputs (canonical rows) back to input rows; duplicates share their first copy's.
/// Each row is written once, by the thread of its canonical point (no serial fill first).
void scatter_side(const CanonicalSide& cs, const IndexMatrix& knn, const detail::Canonical& canon,
                  int threads, detail::GeometrySide& side) {
  const Eigen::Index n = Eigen::Index(canon.copies.size());
  const Eigen::Index kn = std::min<Eigen::Index>(kMixNeighbours, knn.cols());
  size_side(n, kn, cs.members.rows() > 0, side);
  const bool weighted = cs.weight.size() == cs.pca.rows();
  auto put = [](Normals& out, int64_t row, const Eigen::RowVector3d& v) {
    if (v.allFinite())
      out.row(row) = v.normalized();  // as scatter()
    else
      out.row(row).setConstant(std::numeric_limits<double>::quiet_NaN());
  };
  // Each canonical point writes its own input row: the points in parallel.
  detail::parallel_for(cs.pca.rows(), threads, nullptr, [&](int64_t i) {
    const int64_t row = canon.rows[size_t(i)];
    put(side.pca, row, cs.pca.row(i));
    put(side.jet, row, cs.jet.row(i));
    put(side.half, row, cs.half.row(i));
    side.half_variation[row] = cs.half_variation[i];
    put_radial(side.radial, row, cs.radial, i);
    put_radial(side.radial_half, row, cs.radial_half, i);
    side.blend_weight[row] = weighted ? cs.weight[i] : 0.0;
    for (Eigen::Index j = 0; j < kn; ++j) side.knn(row, j) = int32_t(canon.rows[size_t(knn(i, j))]);
    for (Eigen::Index j = 0; j < cs.members.cols(); ++j)
      side.members(row, j) = int32_t(canon.rows[size_t(cs.members(i, j))]);
  });
  for (Eigen::Index r = 0; r < n; ++r)
    if (canon.copies[size_t(r)] < 0) blank_side_row(r, side);  // not finite
  detail::copy_to_duplicates(canon.copies, [&](Eigen::Index i, Eigen::Index first) {
    for (Normals* out : {&side.pca, &side.jet, &side.half}) out->row(i) = out->row(first);
    side.blend_weight[i] = side.blend_weight[first];
    side.half_variation[i] = side.half_variation[first];
    put_radial(side.radial, i, side.radial, first);
    put_radial(side.radial_half, i, side.radial_half, first);
    side.knn.row(i) = side.knn.row(first);
    if (side.members.rows() > 0) side.members.row(i) = side.members.row(first);
  });
}

/// Unit normals and curvatures of the canonical points back to their input rows.
void scatter(const Normals& out, const Eigen::VectorXd& variation,
             const std::vector<int64_t>& finite, EstimateResult& res) {
  for (Eigen::Index i = 0; i < out.rows(); ++i) {
    const Eigen::RowVector3d nrm = out.row(i);
    if (nrm.allFinite() && nrm.squaredNorm() > 0.5) {
      res.normals.row(finite[size_t(i)]) = nrm.normalized();
      res.valid[size_t(finite[size_t(i)])] = 1;
      res.curvature[finite[size_t(i)]] = variation[i];
    }
  }
}

}  // namespace

namespace detail {

EstimateResult empty_result(Eigen::Index n) {
  EstimateResult res;
  res.normals.setConstant(n, 3, std::numeric_limits<double>::quiet_NaN());
  res.valid.assign(size_t(n), 0);
  res.curvature.setConstant(n, std::numeric_limits<double>::quiet_NaN());
  return res;
}

EstimateResult estimate_geometry(const Points& points, const EstimateOptions& options,
                                 const TileOverrides& overrides, GeometrySide* side,
                                 SharedTable* table) {
  start_threads(options.run.threads);  // before the big allocations
  EstimateResult res = empty_result(points.rows());
  Prepared own;
  const bool given = overrides.prepared && overrides.prepared->source == points.data();
  Prepared& prep = given ? *overrides.prepared : own;
  if (!given) prep.canon = canonical_points(points, prep.warnings);
  res.warnings = std::move(prep.warnings);
  Canonical& canon = prep.canon;  // rows move to `table` at the end
  const Points& pts = canon.pts;
  const RunContext& run = options.run;
  Progress top(run.progress);
  if (run.progress) top.stage("kd-tree", 0, 0.02);
  if (!prep.tree) prep.tree = std::make_unique<Neighbors>(pts);
  const Neighbors& tree = *prep.tree;
  top.throw_if_cancelled();

  IndexMatrix knn;
  measure_noise(pts, tree, canon.unit, options, overrides, knn, res);
  const double spacing = res.spacing;  // normalised units, for the stages below
  const ScaleChoice choice = choose_sizes(options, pts.rows(), res);
  const int kdepth = table_depth(options, choice, pts.rows(), res);
  const int shared = shared_columns(options, canon);
  const int kdesc = descriptor_depth(table, canon, choice);           // 0: no table handed on
  const int kfit = fit_depth(options, side, res.k_used, pts.rows());  // 0: no learned fit
  neighbour_table(tree, std::max({kdepth, shared, kdesc, kfit}), run, knn);
  share_neighbours(knn, canon, shared, run, res);
  // The stages take their sizes, not the table's width.
  const int keep = std::max({kdepth, kdesc, kfit});
  if (knn.cols() > keep) knn = knn.leftCols(keep).eval();  // only what the stages use

  // MFPS: the bandwidth's planes; the candidate mix: the radial candidates of the same planes.
  const PcaOptions pca_options{res.k_used, options.method == Method::Mfps, side != nullptr};
  PcaResult pca = pca_normals(pts, knn, pca_options, narrow(run, 0.35, 0.45));
  Normals out = pca.normals;
  Eigen::VectorXd weight;
  if (options.method == Method::Mfps) {
    out = mfps_stage(pts, knn, pca, MfpsInput{canon.rows, choice, kdepth, spacing}, options,
                     overrides, res, side ? &weight : nullptr);
    drop_planeless(pts, knn, kdepth, pca.normals, out);
  }
  scatter(out, pca.variation, canon.rows, res);
  if (side) {
    CanonicalSide cs = side_candidates(pts, knn, pca, res.k_used, run);
    cs.weight = std::move(weight);
    if (run.progress) top.stage("fit members", 1, 1);
    cs.members = fit_members(knn, kfit, run.threads);
    if (run.progress) top.stage("side outputs", 1, 1);
    top.throw_if_cancelled();
    scatter_side(cs, knn, canon, run.threads, *side);
  }
  if (kdesc > 0) {
    table->knn = std::move(knn);
    table->rows = std::move(canon.rows);  // not used below
  }
  res.spacing = spacing * canon.unit;
  finish_result(res, canon.copies, canon.finite_count);
  if (run.progress) {
    top.stage("done", 1, 1);
    top.throw_if_cancelled();
  }
  return res;
}

EstimateResult estimate_cloud(const Points& points, const EstimateOptions& options,
                              const TileOverrides& overrides) {
  if (options.method == Method::NhNet) return estimate_nhnet(points, options, overrides);
  return estimate_geometry(points, options, overrides);
}

}  // namespace detail

void hand_neighbours(EstimateResult& res, OrientOptions& orient) {
  if (res.neighbours.size() > 0)
    orient.neighbours = std::make_shared<const IndexMatrix>(std::move(res.neighbours));
  res.neighbours.resize(0, 0);
}

namespace detail {

EstimateResult estimate_points(const Points& points, const EstimateOptions& options,
                               const TileOverrides& overrides) {
  if (wants_tiles(points, options)) return estimate_tiled(points, options, overrides.prepared);
  return estimate_cloud(points, options, overrides);
}

void add_confidence(const Points& points, const EstimateOptions& options, EstimateResult& res) {
  if (!options.confidence || res.confidence.size() != 0) return;  // cell means blend their own
  const ConfidenceModel model = options.method == Method::Pca    ? ConfidenceModel::Pca
                                : options.method == Method::Mfps ? ConfidenceModel::Mfps
                                                                 : ConfidenceModel::NhNet;
  const IndexMatrix* table = res.neighbours.rows() == points.rows() ? &res.neighbours : nullptr;
  res.confidence = normal_confidence(points, res.normals, res.curvature, res.noise_ratio, model,
                                     options.run, table);
}

namespace {

EstimateResult estimate_unscored(const Points& points, const EstimateOptions& options,
                                 MeansRun* keep) {
  EstimateResult res;
  TileOverrides measured;
  Prepared prepared;
  if (through_cell_means(points, options, res, measured, prepared, keep)) return res;
  if (!(measured.spacing > 0)) return estimate_points(points, options, measured);
  EstimateOptions rest = options;  // the decision's probe reported the first 4 %
  rest.run = narrow(options.run, 0.04, 1);
  // Its canonical points, tree and probe serve the estimate (one piece or tiles) instead of
  // being built again.
  measured.prepared = &prepared;
  return estimate_points(points, rest, measured);
}

}  // namespace

EstimateResult estimate_normals_keeping_means(const Points& points, const EstimateOptions& options,
                                              MeansRun* keep) {
  check_options(options);
  EstimateOptions estimate = options;
  if (options.confidence) {
    estimate.run = narrow(options.run, 0, 0.97);
    // the estimate's own neighbour table, when it can give one, spares the confidence a search
    estimate.neighbours = std::max(options.neighbours, kConfidenceNeighbours);
  }
  EstimateResult res = estimate_unscored(points, estimate, keep);
  EstimateOptions scored = options;
  scored.run = narrow(options.run, 0.97, 1);
  add_confidence(points, scored, res);
  if (res.neighbours.cols() > options.neighbours)  // deeper only for the confidence
    res.neighbours =
        options.neighbours > 0 ? res.neighbours.leftCols(options.neighbours).eval() : IndexMatrix();
  return res;
}

}  // namespace detail

EstimateResult estimate_normals(const Points& points, const EstimateOptions& options) {
  return detail::estimate_normals_keeping_means(points, options, nullptr);
}

}  // namespace nhnet
