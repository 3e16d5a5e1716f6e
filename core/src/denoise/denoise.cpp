// Normal-guided denoising (paper Sec. 7, Eq. 9); see denoise.hpp for the reading of the equation
// and its sign-invariant form. Ball neighbourhoods are found once (one kd-tree) and stored as a
// compressed row table; every iteration is a Jacobi step (all points read the previous positions).
#include "nhnet/denoise/denoise.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

namespace nhnet {

namespace {

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

}  // namespace

double average_spacing(const Points& points, int k, const RunContext& run) {
  if (k < 1) throw InvalidOptions("average_spacing: k must be >= 1");
  if (points.rows() < 2) throw UnprocessableInput("average_spacing needs at least 2 points");
  return spacing_from_tree(Neighbors(points), k, run);
}

DenoiseResult denoise_points(const Points& points, const Normals& normals,
                             const DenoiseOptions& options) {
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
  detail::start_threads(options.run.threads);  // before the big allocations

  DenoiseResult res;
  res.points = points;
  res.sigma = options.sigma;
  const Eigen::Index n = points.rows();

  // Usable points: finite coordinates and a finite, non-zero normal (made unit here).
  std::vector<int64_t> used;
  used.reserve(size_t(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    const double len = normals.row(i).norm();
    if (points.row(i).allFinite() && std::isfinite(len) && len > 1e-12) used.push_back(i);
  }
  res.skipped = n - int64_t(used.size());
  if (used.size() < 2)
    throw UnprocessableInput("only " + std::to_string(used.size()) +
                             " points have finite coordinates and a valid normal; denoising "
                             "needs at least 2");
  const Eigen::Index m = Eigen::Index(used.size());
  Points pts(m, 3);
  Normals nrm(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    pts.row(i) = points.row(used[size_t(i)]);
    nrm.row(i) = normals.row(used[size_t(i)]).normalized();
  }

  const RunContext& run = options.run;
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("kd-tree", 0, 0.02);
  const Neighbors tree(pts);
  progress.throw_if_cancelled();

  // Radius: given, or from the average spacing.
  if (options.radius > 0) {
    res.radius = options.radius;
  } else {
    RunContext sub;
    sub.threads = run.threads;
    res.spacing = spacing_from_tree(tree, 6, sub);
    res.radius = options.radius_factor * res.spacing;
    if (!(res.radius > 0))
      throw UnprocessableInput("denoise: the points have zero average spacing (all identical?); "
                               "give a radius");
  }

  // Ball neighbourhoods (self excluded), computed once on the input positions.
  if (run.progress) progress.stage("neighbourhoods", 0.02, 0.12);
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
  std::vector<int64_t> offset(size_t(m) + 1, 0);
  for (Eigen::Index i = 0; i < m; ++i)
    offset[size_t(i) + 1] = offset[size_t(i)] + int64_t(balls[size_t(i)].size());
  std::vector<int32_t> nb(size_t(offset.back()));
  for (Eigen::Index i = 0; i < m; ++i) {
    std::copy(balls[size_t(i)].begin(), balls[size_t(i)].end(), nb.begin() + offset[size_t(i)]);
    std::vector<int32_t>().swap(balls[size_t(i)]);
  }
  const int64_t n_capped = std::count(capped.begin(), capped.end(), uint8_t(1));
  if (n_capped > 0)
    res.warnings.push_back(std::to_string(n_capped) + " balls held more than " +
                           std::to_string(options.max_neighbors) +
                           " points and kept only the nearest; is the radius too large?");

  // Thin parts: drop the neighbours that lie on another sheet parallel to p_i's (the other side
  // of a blade or a wall): normal parallel to n_i but far off p_i's tangent plane, further than
  // sheet_gap x the typical offset of the parallel neighbours (a noise measure: the median over
  // the points of their median |(p_j - p_i) . n_i|). Neighbours across a sharp edge are not
  // parallel and stay.
  if (options.sheet_gap > 0) {
    const double cos_parallel = std::cos(30.0 * M_PI / 180.0);
    std::vector<double> typical(static_cast<size_t>(m), -1.0);
    detail::parallel_for(m, run.threads, nullptr, [&](int64_t i) {
      thread_local std::vector<double> off;
      off.clear();
      const Eigen::RowVector3d ni = nrm.row(i), pi = pts.row(i);
      for (int64_t e = offset[size_t(i)]; e < offset[size_t(i) + 1]; ++e) {
        const int32_t j = nb[size_t(e)];
        if (std::abs(ni.dot(nrm.row(j))) >= cos_parallel)
          off.push_back(std::abs(ni.dot(pts.row(j) - pi)));
      }
      if (off.empty()) return;
      std::nth_element(off.begin(), off.begin() + off.size() / 2, off.end());
      typical[size_t(i)] = off[off.size() / 2];
    });
    typical.erase(std::remove(typical.begin(), typical.end(), -1.0), typical.end());
    if (!typical.empty()) {
      std::nth_element(typical.begin(), typical.begin() + typical.size() / 2, typical.end());
      res.sheet_gap = options.sheet_gap * typical[typical.size() / 2];
    }
    if (res.sheet_gap > 0) {
      std::vector<int64_t> keep_offset(size_t(m) + 1, 0);
      int64_t w = 0;
      for (Eigen::Index i = 0; i < m; ++i) {
        const Eigen::RowVector3d ni = nrm.row(i), pi = pts.row(i);
        const int64_t b = offset[size_t(i)], e = offset[size_t(i) + 1];
        keep_offset[size_t(i)] = w;
        for (int64_t q = b; q < e; ++q) {
          const int32_t j = nb[size_t(q)];
          const bool other_sheet = std::abs(ni.dot(nrm.row(j))) >= cos_parallel &&
                                   std::abs(ni.dot(pts.row(j) - pi)) > res.sheet_gap;
          if (other_sheet)
            ++res.other_sheet;
          else
            nb[size_t(w++)] = j;
        }
      }
      keep_offset[size_t(m)] = w;
      nb.resize(size_t(w));
      offset.swap(keep_offset);
    }
  }

  int64_t moved = 0, total_nb = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const int64_t c = offset[size_t(i) + 1] - offset[size_t(i)];
    if (c > 0) {
      ++moved;
      total_nb += c;
    }
  }
  res.moved = moved;
  res.isolated = m - moved;
  res.mean_neighbors = moved > 0 ? double(total_nb) / double(moved) : 0.0;

  // Per-pair constants (neighbourhoods and normals are fixed): the sign s_ij aligning n_j with
  // n_i and the weight w_ij of the aligned pair.
  const double inv_s2 = 1.0 / (options.sigma * options.sigma);
  std::vector<float> weight(nb.size());
  std::vector<int8_t> sign(nb.size());
  for (Eigen::Index i = 0; i < m; ++i)
    for (int64_t e = offset[size_t(i)]; e < offset[size_t(i) + 1]; ++e) {
      const double d = nrm.row(i).dot(nrm.row(nb[size_t(e)]));
      sign[size_t(e)] = d < 0 ? int8_t(-1) : int8_t(1);
      // ||n_i - s n_j||^2 = 2 - 2 |n_i . n_j| for unit normals.
      weight[size_t(e)] = float(std::exp(-(2.0 - 2.0 * std::abs(d)) * inv_s2));
    }

  // Roughness of positions q: the median over the points of the mean |(q_j - q_i) . n_i| over
  // their neighbours with a near-parallel normal (same smooth sheet). Noise raises it; a shift
  // of whole regions (Eq. 9's drift on curved parts) does not.
  const double cos_par = std::cos(30.0 * M_PI / 180.0);
  std::vector<uint8_t> parallel(nb.size());
  for (Eigen::Index i = 0; i < m; ++i)
    for (int64_t e = offset[size_t(i)]; e < offset[size_t(i) + 1]; ++e)
      parallel[size_t(e)] = std::abs(nrm.row(i).dot(nrm.row(nb[size_t(e)]))) >= cos_par;
  std::vector<double> rough_pt(static_cast<size_t>(m));
  auto roughness = [&](const Points& q) {
    detail::parallel_for(m, run.threads, nullptr, [&](int64_t i) {
      double sum = 0;
      int cnt = 0;
      for (int64_t e = offset[size_t(i)]; e < offset[size_t(i) + 1]; ++e)
        if (parallel[size_t(e)]) {
          sum += std::abs(nrm.row(i).dot(q.row(nb[size_t(e)]) - q.row(i)));
          ++cnt;
        }
      rough_pt[size_t(i)] = cnt > 0 ? sum / cnt : -1.0;
    });
    std::vector<double> r;
    r.reserve(rough_pt.size());
    for (double v : rough_pt)
      if (v >= 0) r.push_back(v);
    if (r.empty()) return 0.0;
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    return r[r.size() / 2];
  };

  // Iterations (Jacobi: every point reads the positions of the previous step).
  Points cur = pts, next = pts;
  const double lambda = options.lambda;
  res.roughness.push_back(roughness(cur));
  for (int it = 0; it < options.iterations; ++it) {
    if (run.progress)
      progress.stage("denoising", 0.12 + 0.88 * it / options.iterations,
                     0.12 + 0.88 * (it + 1) / options.iterations);
    detail::parallel_for(m, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
      const int64_t b = offset[size_t(i)], e = offset[size_t(i) + 1];
      if (b == e) return;
      const Eigen::Vector3d pi = cur.row(i).transpose(), ni = nrm.row(i).transpose();
      Eigen::Vector3d delta = Eigen::Vector3d::Zero();
      for (int64_t q = b; q < e; ++q) {
        const int32_t j = nb[size_t(q)];
        const Eigen::Vector3d d = cur.row(j).transpose() - pi;
        const Eigen::Vector3d nj = nrm.row(j).transpose();
        // w (d . n_i) s n_j + lambda (d . n_j) n_j
        delta += (double(weight[size_t(q)]) * double(sign[size_t(q)]) * d.dot(ni) +
                  lambda * d.dot(nj)) * nj;
      }
      next.row(i) = (pi + options.step / double(e - b) * delta).transpose();
    });
    std::swap(cur, next);
    res.iterations = it + 1;
    res.roughness.push_back(roughness(cur));
    const size_t t = res.roughness.size() - 1;
    if (options.stop_drop > 0 && res.roughness[t] > (1.0 - options.stop_drop) * res.roughness[t - 1])
      break;
  }

  for (Eigen::Index i = 0; i < m; ++i) res.points.row(used[size_t(i)]) = cur.row(i);
  if (run.progress) {
    progress.stage("done", 1, 1);
    progress.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
