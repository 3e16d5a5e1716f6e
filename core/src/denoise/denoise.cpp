// Normal-guided denoising (paper Sec. 7, Eq. 9); see denoise.hpp for the reading of the equation
// and its sign-invariant form. Ball neighbourhoods are found once (one kd-tree) and stored as a
// compressed row table; every iteration is a Jacobi step (all points read the previous positions).
#include "nhnet/denoise/denoise.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>

namespace nhnet {

namespace {

/// The usable points (finite coordinates, finite non-zero normal): their rows in the input,
/// their coordinates and their normals made unit.
struct UsablePoints {
  std::vector<int64_t> rows;
  Points pts;
  Normals nrm;
};

/// The neighbourhoods N_i as a compressed row table: N_i = nb[offset[i]] .. nb[offset[i + 1] - 1].
struct Neighbourhoods {
  std::vector<int64_t> offset;
  std::vector<int32_t> nb;
};

/// Per-pair constants of Eq. 9 (neighbourhoods and normals are fixed): the sign s_ij aligning
/// n_j with n_i and the weight w_ij of the aligned pair, one entry per table entry.
struct PairTerms {
  std::vector<float> weight;
  std::vector<int8_t> sign;
};

/// |n_i . n_j| at or above this counts as parallel normals (within 30 degrees).
double cos_parallel() { return std::cos(30.0 * M_PI / 180.0); }

/// The element at v.size() / 2 in sorted order (the upper median); reorders v, which must not
/// be empty.
double upper_median(std::vector<double>& v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Throws InvalidOptions for mismatched sizes or an option out of its range.
void check_options(const Points& points, const Normals& normals, const DenoiseOptions& options) {
  if (normals.rows() != points.rows())
    throw InvalidOptions("denoise: " + std::to_string(normals.rows()) + " normals for " +
                         std::to_string(points.rows()) + " points");
  if (options.iterations < 0) throw InvalidOptions("denoise: iterations must be >= 0");
  if (!(options.radius >= 0) || !std::isfinite(options.radius))
    throw InvalidOptions("denoise: radius must be a finite number >= 0 (0 = automatic)");
  if (!(options.radius_factor > 0)) throw InvalidOptions("denoise: radius factor must be > 0");
  if (!(options.sigma > 0)) throw InvalidOptions("denoise: sigma must be > 0");
  if (!(options.lambda >= 0)) throw InvalidOptions("denoise: lambda must be >= 0");
  if (!(options.step > 0)) throw InvalidOptions("denoise: step must be > 0");
  if (options.max_neighbors < 0) throw InvalidOptions("denoise: max_neighbors must be >= 0");
  if (options.run.threads < 0) throw InvalidOptions("denoise: threads must be >= 0");
}

/// Usable points: finite coordinates and a finite, non-zero normal (made unit here); the others
/// are counted in res.skipped. Throws UnprocessableInput when fewer than 2 remain.
UsablePoints usable_points(const Points& points, const Normals& normals, DenoiseResult& res) {
  const Eigen::Index n = points.rows();
  UsablePoints in;
  in.rows.reserve(size_t(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    const double len = normals.row(i).norm();
    if (points.row(i).allFinite() && std::isfinite(len) && len > 1e-12) in.rows.push_back(i);
  }
  res.skipped = n - int64_t(in.rows.size());
  if (in.rows.size() < 2)
    throw UnprocessableInput("only " + std::to_string(in.rows.size()) +
                             " points have finite coordinates and a valid normal; denoising "
                             "needs at least 2");
  const Eigen::Index m = Eigen::Index(in.rows.size());
  in.pts.resize(m, 3);
  in.nrm.resize(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    in.pts.row(i) = points.row(in.rows[size_t(i)]);
    in.nrm.row(i) = normals.row(in.rows[size_t(i)]).normalized();
  }
  return in;
}

/// Average spacing: mean over the points of the mean distance to their `k` nearest other points
/// (CGAL's compute_average_spacing definition).
double spacing_from_tree(const Neighbors& tree, int k, const RunContext& run) {
  IndexMatrix knn;
  DistanceMatrix d2;
  tree.knn_all(k + 1, knn, &d2, run);  // column 0 is the point itself
  const Eigen::Index n = knn.rows(), kk = knn.cols();
  if (kk < 2) return 0;
  double sum = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    double s = 0;
    for (Eigen::Index c = 1; c < kk; ++c) s += std::sqrt(double(d2(i, c)));
    sum += s / double(kk - 1);
  }
  return sum / double(n);
}

/// Radius of the balls N_i: the given one, or radius_factor x the average spacing (6 neighbours).
void choose_radius(const Neighbors& tree, const DenoiseOptions& options, DenoiseResult& res) {
  if (options.radius > 0) {
    res.radius = options.radius;
    return;
  }
  RunContext sub;
  sub.threads = options.run.threads;
  res.spacing = spacing_from_tree(tree, 6, sub);
  res.radius = options.radius_factor * res.spacing;
  if (!(res.radius > 0))
    throw UnprocessableInput(
        "denoise: the points have zero average spacing (all identical?); "
        "give a radius");
}

/// Packs per-point neighbour lists into a compressed row table, freeing each list once copied.
Neighbourhoods pack_rows(std::vector<std::vector<int32_t>>& balls) {
  const size_t m = balls.size();
  Neighbourhoods nbh;
  nbh.offset.assign(m + 1, 0);
  for (size_t i = 0; i < m; ++i) nbh.offset[i + 1] = nbh.offset[i] + int64_t(balls[i].size());
  nbh.nb.resize(size_t(nbh.offset.back()));
  for (size_t i = 0; i < m; ++i) {
    std::copy(balls[i].begin(), balls[i].end(), nbh.nb.begin() + nbh.offset[i]);
    std::vector<int32_t>().swap(balls[i]);
  }
  return nbh;
}

/// Ball neighbourhoods N_i (self excluded, at most max_neighbors nearest), found once on the
/// input positions; warns in res.warnings when balls were capped.
Neighbourhoods ball_neighbourhoods(const Neighbors& tree, const Points& pts,
                                   const DenoiseOptions& options, detail::Progress& progress,
                                   DenoiseResult& res) {
  const Eigen::Index m = pts.rows();
  const RunContext& run = options.run;
  std::vector<std::vector<int32_t>> balls(static_cast<size_t>(m));
  std::vector<uint8_t> capped(size_t(m), 0);
  detail::parallel_for(m, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    thread_local std::vector<std::pair<int32_t, float>> found;
    tree.radius(pts.row(i).transpose(), res.radius, found);
    std::vector<int32_t>& b = balls[size_t(i)];
    b.reserve(found.size());
    for (const auto& f : found) {
      if (f.first == int32_t(i)) continue;
      if (options.max_neighbors > 0 && int(b.size()) >= options.max_neighbors) {
        capped[size_t(i)] = 1;
        break;
      }
      b.push_back(f.first);
    }
  });
  Neighbourhoods nbh = pack_rows(balls);
  const int64_t n_capped = std::count(capped.begin(), capped.end(), uint8_t(1));
  if (n_capped > 0)
    res.warnings.push_back(std::to_string(n_capped) + " balls held more than " +
                           std::to_string(options.max_neighbors) +
                           " points and kept only the nearest; is the radius too large?");
  return nbh;
}

/// Typical offset of the parallel neighbours (a noise measure): the median over the points of
/// their median |(p_j - p_i) . n_i| over the neighbours with a parallel normal; none when no
/// point has such a neighbour.
std::optional<double> typical_parallel_offset(const Neighbourhoods& nbh, const UsablePoints& in,
                                              int threads) {
  const Eigen::Index m = in.pts.rows();
  const double cos_par = cos_parallel();
  std::vector<double> typical(static_cast<size_t>(m), -1.0);
  detail::parallel_for(m, threads, nullptr, [&](int64_t i) {
    thread_local std::vector<double> off;
    off.clear();
    const Eigen::RowVector3d ni = in.nrm.row(i), pi = in.pts.row(i);
    for (int64_t e = nbh.offset[size_t(i)]; e < nbh.offset[size_t(i) + 1]; ++e) {
      const int32_t j = nbh.nb[size_t(e)];
      if (std::abs(ni.dot(in.nrm.row(j))) >= cos_par)
        off.push_back(std::abs(ni.dot(in.pts.row(j) - pi)));
    }
    if (off.empty()) return;
    typical[size_t(i)] = upper_median(off);
  });
  typical.erase(std::remove(typical.begin(), typical.end(), -1.0), typical.end());
  if (typical.empty()) return std::nullopt;
  return upper_median(typical);
}

/// Removes from N_i the neighbours on another sheet (parallel normal but further than `gap` off
/// p_i's tangent plane); returns how many were removed.
int64_t drop_other_sheets(Neighbourhoods& nbh, const UsablePoints& in, double gap) {
  const Eigen::Index m = in.pts.rows();
  const double cos_par = cos_parallel();
  int64_t removed = 0;
  std::vector<int64_t> keep_offset(size_t(m) + 1, 0);
  int64_t w = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const Eigen::RowVector3d ni = in.nrm.row(i), pi = in.pts.row(i);
    const int64_t b = nbh.offset[size_t(i)], e = nbh.offset[size_t(i) + 1];
    keep_offset[size_t(i)] = w;
    for (int64_t q = b; q < e; ++q) {
      const int32_t j = nbh.nb[size_t(q)];
      const bool other_sheet =
          std::abs(ni.dot(in.nrm.row(j))) >= cos_par && std::abs(ni.dot(in.pts.row(j) - pi)) > gap;
      if (other_sheet)
        ++removed;
      else
        nbh.nb[size_t(w++)] = j;
    }
  }
  keep_offset[size_t(m)] = w;
  nbh.nb.resize(size_t(w));
  nbh.offset.swap(keep_offset);
  return removed;
}

/// Thin parts: drops the neighbours that lie on another sheet parallel to p_i's (the other side
/// of a blade or a wall): normal parallel to n_i but further off p_i's tangent plane than
/// sheet_gap x the typical offset of the parallel neighbours. Neighbours across a sharp edge are
/// not parallel and stay.
void exclude_other_sheets(Neighbourhoods& nbh, const UsablePoints& in,
                          const DenoiseOptions& options, DenoiseResult& res) {
  if (!(options.sheet_gap > 0)) return;
  const std::optional<double> typical = typical_parallel_offset(nbh, in, options.run.threads);
  if (typical) res.sheet_gap = options.sheet_gap * *typical;
  if (res.sheet_gap > 0) res.other_sheet = drop_other_sheets(nbh, in, res.sheet_gap);
}

/// Result counts: points moved (non-empty N_i), isolated (empty N_i) and the mean |N_i| of the
/// moved ones.
void count_neighbourhoods(const Neighbourhoods& nbh, DenoiseResult& res) {
  const Eigen::Index m = Eigen::Index(nbh.offset.size()) - 1;
  int64_t moved = 0, total_nb = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const int64_t c = nbh.offset[size_t(i) + 1] - nbh.offset[size_t(i)];
    if (c > 0) {
      ++moved;
      total_nb += c;
    }
  }
  res.moved = moved;
  res.isolated = m - moved;
  res.mean_neighbors = moved > 0 ? double(total_nb) / double(moved) : 0.0;
}

/// Per-pair constants of Eq. 9: s_ij = sign(n_i . n_j) and w_ij = exp(-||n_i - s_ij n_j||^2 /
/// sigma^2).
PairTerms pair_terms(const Neighbourhoods& nbh, const Normals& nrm, double sigma) {
  const Eigen::Index m = nrm.rows();
  const double inv_s2 = 1.0 / (sigma * sigma);
  PairTerms pair;
  pair.weight.resize(nbh.nb.size());
  pair.sign.resize(nbh.nb.size());
  for (Eigen::Index i = 0; i < m; ++i)
    for (int64_t e = nbh.offset[size_t(i)]; e < nbh.offset[size_t(i) + 1]; ++e) {
      const double d = nrm.row(i).dot(nrm.row(nbh.nb[size_t(e)]));
      pair.sign[size_t(e)] = d < 0 ? int8_t(-1) : int8_t(1);
      // ||n_i - s n_j||^2 = 2 - 2 |n_i . n_j| for unit normals.
      pair.weight[size_t(e)] = float(std::exp(-(2.0 - 2.0 * std::abs(d)) * inv_s2));
    }
  return pair;
}

/// Roughness of positions q: the median over the points of the mean |(q_j - q_i) . n_i| over
/// their neighbours with a near-parallel normal (same smooth sheet). Noise raises it; a shift
/// of whole regions (Eq. 9's drift on curved parts) does not.
class Roughness {
 public:
  Roughness(const Neighbourhoods& nbh, const Normals& nrm, int threads)
      : nbh_(nbh), nrm_(nrm), threads_(threads), per_point_(size_t(nrm.rows())) {
    const double cos_par = cos_parallel();
    parallel_.resize(nbh.nb.size());
    for (Eigen::Index i = 0; i < nrm.rows(); ++i)
      for (int64_t e = nbh.offset[size_t(i)]; e < nbh.offset[size_t(i) + 1]; ++e)
        parallel_[size_t(e)] = std::abs(nrm.row(i).dot(nrm.row(nbh.nb[size_t(e)]))) >= cos_par;
  }

  /// The roughness of positions q (0 when no point has a parallel neighbour).
  double operator()(const Points& q) {
    detail::parallel_for(nrm_.rows(), threads_, nullptr, [&](int64_t i) {
      double sum = 0;
      int cnt = 0;
      for (int64_t e = nbh_.offset[size_t(i)]; e < nbh_.offset[size_t(i) + 1]; ++e)
        if (parallel_[size_t(e)]) {
          sum += std::abs(nrm_.row(i).dot(q.row(nbh_.nb[size_t(e)]) - q.row(i)));
          ++cnt;
        }
      per_point_[size_t(i)] = cnt > 0 ? sum / cnt : -1.0;
    });
    std::vector<double> r;
    r.reserve(per_point_.size());
    for (double v : per_point_)
      if (v >= 0) r.push_back(v);
    if (r.empty()) return 0.0;
    return upper_median(r);
  }

 private:
  const Neighbourhoods& nbh_;
  const Normals& nrm_;
  int threads_;
  std::vector<uint8_t> parallel_;
  std::vector<double> per_point_;
};

/// One Jacobi step of Eq. 9 from `cur` into `next`: p_i' = p_i + step / |N_i| sum_j
/// (w_ij s_ij (d . n_i) + lambda (d . n_j)) n_j with d = p_j - p_i (isolated points untouched).
void eq9_step(const Neighbourhoods& nbh, const PairTerms& pair, const Normals& nrm,
              const DenoiseOptions& options, detail::Progress* progress, const Points& cur,
              Points& next) {
  const double lambda = options.lambda;
  detail::parallel_for(nrm.rows(), options.run.threads, progress, [&](int64_t i) {
    const int64_t b = nbh.offset[size_t(i)], e = nbh.offset[size_t(i) + 1];
    if (b == e) return;
    const Eigen::Vector3d pi = cur.row(i).transpose(), ni = nrm.row(i).transpose();
    Eigen::Vector3d delta = Eigen::Vector3d::Zero();
    for (int64_t q = b; q < e; ++q) {
      const int32_t j = nbh.nb[size_t(q)];
      const Eigen::Vector3d d = cur.row(j).transpose() - pi;
      const Eigen::Vector3d nj = nrm.row(j).transpose();
      // w (d . n_i) s n_j + lambda (d . n_j) n_j
      delta += (double(pair.weight[size_t(q)]) * double(pair.sign[size_t(q)]) * d.dot(ni) +
                lambda * d.dot(nj)) *
               nj;
    }
    next.row(i) = (pi + options.step / double(e - b) * delta).transpose();
  });
}

/// Iterations of Eq. 9 (Jacobi: every point reads the positions of the previous step), stopped
/// once a step lowers the roughness by less than stop_drop; returns the final positions and
/// records res.iterations and res.roughness.
Points iterate_eq9(const UsablePoints& in, const Neighbourhoods& nbh, const DenoiseOptions& options,
                   detail::Progress& progress, DenoiseResult& res) {
  const RunContext& run = options.run;
  const PairTerms pair = pair_terms(nbh, in.nrm, options.sigma);
  Roughness roughness(nbh, in.nrm, run.threads);
  Points cur = in.pts, next = in.pts;
  res.roughness.push_back(roughness(cur));
  for (int it = 0; it < options.iterations; ++it) {
    if (run.progress)
      progress.stage("denoising", 0.12 + 0.88 * it / options.iterations,
                     0.12 + 0.88 * (it + 1) / options.iterations);
    eq9_step(nbh, pair, in.nrm, options, run.progress ? &progress : nullptr, cur, next);
    std::swap(cur, next);
    res.iterations = it + 1;
    res.roughness.push_back(roughness(cur));
    const size_t t = res.roughness.size() - 1;
    if (options.stop_drop > 0 &&
        res.roughness[t] > (1.0 - options.stop_drop) * res.roughness[t - 1])
      break;
  }
  return cur;
}

}  // namespace

DenoiseResult denoise_points(const Points& points, const Normals& normals,
                             const DenoiseOptions& options) {
  check_options(points, normals, options);
  detail::start_threads(options.run.threads);  // before the big allocations

  DenoiseResult res;
  res.points = points;
  res.sigma = options.sigma;
  const UsablePoints in = usable_points(points, normals, res);

  const RunContext& run = options.run;
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("kd-tree", 0, 0.02);
  const Neighbors tree(in.pts);
  progress.throw_if_cancelled();
  choose_radius(tree, options, res);

  if (run.progress) progress.stage("neighbourhoods", 0.02, 0.12);
  Neighbourhoods nbh = ball_neighbourhoods(tree, in.pts, options, progress, res);
  exclude_other_sheets(nbh, in, options, res);
  count_neighbourhoods(nbh, res);

  const Points cur = iterate_eq9(in, nbh, options, progress, res);
  for (Eigen::Index i = 0; i < cur.rows(); ++i) res.points.row(in.rows[size_t(i)]) = cur.row(i);
  if (run.progress) {
    progress.stage("done", 1, 1);
    progress.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
