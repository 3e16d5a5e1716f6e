// Multi-scale fitting patch selection: paper Eq. 1-4 (Sec. 4.1-4.2). See mfps.hpp for the
// choices the paper leaves open.
#include "nhnet/geometry/mfps.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "util/fast_math.hpp"
#include "util/parallel.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace nhnet {

namespace {

/// splitmix64: small, fast, good enough to draw sample indices (seeded per scale, see below) so results do
/// not depend on scheduling.
struct SplitMix {
  uint64_t s;
  uint64_t next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  int below(int n) { return int(next() % uint64_t(n)); }
};

struct Plane {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();  // unit normal
  Eigen::Vector3d c = Eigen::Vector3d::Zero();  // point on the plane (patch-local coordinates)
};

/// Least-squares plane of weighted patch-local points; false when degenerate.
bool weighted_plane(const std::vector<Eigen::Vector3d>& q, const double* w, Plane& out) {
  double ws = 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < q.size(); ++k) {
    ws += w[k];
    c += w[k] * q[k];
  }
  if (!(ws > 0)) return false;
  c /= ws;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < q.size(); ++k) {
    const Eigen::Vector3d d = q[k] - c;
    cov.noalias() += w[k] * d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Vector3d ev = es.eigenvalues();
  if (!(ev[1] > 1e-14 * std::max(ev[2], 1e-300))) return false;
  out.n = es.eigenvectors().col(0).normalized();
  out.c = c;
  return true;
}

/// Plane through 4 patch-local points (least squares); false when degenerate.
bool four_point_plane(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& d, Plane& out) {
  const Eigen::Vector3d m = 0.25 * (a + b + c + d);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d* p : {&a, &b, &c, &d}) {
    const Eigen::Vector3d e = *p - m;
    cov.noalias() += e * e.transpose();
  }
  if (!detail::smallest_eigenvector(cov, 1e-12, out.n)) return false;
  out.c = m;
  return true;
}

/// E of Eq. 1 (mean Gaussian kernel of residuals) over members `idx` (all if null). With
/// `terms` (all members only), the kernel of every member is stored there too: they are the
/// IRLS weights of that plane, so the refinement does not recompute them.
double objective(const std::vector<Eigen::Vector3d>& q, const Plane& pl, double inv_s2,
                 const std::vector<int>* idx, double* terms = nullptr) {
  thread_local std::vector<double> arg;
  const size_t m = idx ? idx->size() : q.size();
  arg.resize(m);
  for (size_t t = 0; t < m; ++t) {
    const double r = (q[idx ? size_t((*idx)[t]) : t] - pl.c).dot(pl.n);
    arg[t] = -r * r * inv_s2;
  }
  double* kernel = terms ? terms : arg.data();
  detail::exp_nonpositive(arg.data(), kernel, m);
  double e = 0;
  for (size_t t = 0; t < m; ++t) e += kernel[t];
  return e / double(m);
}

/// P(point p lies on face B) for two faces meeting at the edge line of planes (n1, c1) and
/// (n2, c2), each face being the half-plane on the side of its centre c; noise std s. Returns
/// -1 when the planes are (nearly) parallel. `line_distance` (when given and the planes meet)
/// receives the distance from p to the edge line.
double edge_posterior(const Eigen::Vector3d& p, const Eigen::Vector3d& n1, const Eigen::Vector3d& c1,
                      const Eigen::Vector3d& n2, const Eigen::Vector3d& c2, double s,
                      double* line_distance = nullptr) {
  const Eigen::Vector3d d = n1.cross(n2);
  const double dn = d.norm();
  if (!(dn > 1e-3) || !(s > 0)) return -1;
  // A point e on both planes: minimum-norm solution of n1.e = n1.c1, n2.e = n2.c2, d.e = d.p.
  Eigen::Matrix3d a;
  a.row(0) = n1.transpose();
  a.row(1) = n2.transpose();
  a.row(2) = (d / dn).transpose();
  const Eigen::Vector3d b(n1.dot(c1), n2.dot(c2), (d / dn).dot(p));
  const Eigen::Vector3d e = a.partialPivLu().solve(b);
  if (!e.allFinite()) return -1;
  if (line_distance) *line_distance = (p - e).norm();
  auto loglik = [&](const Eigen::Vector3d& n, const Eigen::Vector3d& c) {
    Eigen::Vector3d u = (d / dn).cross(n);
    if ((c - e).dot(u) < 0) u = -u;
    const double r = (p - e).dot(n) / s, t = (p - e).dot(u) / s;
    // log(exp(-r^2/2) Phi(t)), Phi via erfc (accurate in the far tail).
    return -0.5 * r * r + std::log(std::max(0.5 * std::erfc(-t / std::sqrt(2.0)), 1e-300));
  };
  const double la = loglik(n1, c1), lb = loglik(n2, c2);
  return 1.0 / (1.0 + std::exp(std::clamp(la - lb, -700.0, 700.0)));
}

/// Coefficients of the PCA blend (MfpsOptions::pca_blend): the weight is logistic in the
/// features listed at kMfpsBlendFeatures (mfps.hpp; the first is the intercept) and in every
/// product f_a f_b of the others (a <= b), in that order. Fitted by tools/fit_mfps_blend.py on
/// the training split only (16 CAD models x noise 0, 0.1, 0.3, 0.6 %), minimising the mean over
/// clouds of each cloud's mean squared angle error.
constexpr int kBlendTerms = kMfpsBlendFeatures + (kMfpsBlendFeatures - 1) * kMfpsBlendFeatures / 2;
constexpr std::array<double, kBlendTerms> kBlendCoefficients = {
    -10.1513, 9.9937, 9.9467, 12.9313, 10.8916, 0.7740, -5.0653, 3.7326,
    -17.1129, 4.5568, -6.6447, -10.1199, -2.9107, 7.3286, 2.5403, 3.6367,
    1.1171, -3.1667, -2.1574, 4.8027, -3.2419, 21.8807, 2.1296, -5.0413,
    -4.7616, -8.9267, -10.9376, -0.1804, -3.9886, 18.3819, -13.3190, 0.6775,
    10.8244, 7.1389, 1.8630, -7.0517, -4.5196, -9.2979, 16.8540, -9.0520,
    -4.4069, -12.1928, 5.6721, -1.7275, -6.2057, 0.5574, 17.8402, -13.5824,
    9.7896, -7.1143, -7.1633, 2.8672, 3.8743, 4.4842, -8.2935, -25.4468,
    4.7612, 3.6603, -1.3430, -2.9200, -1.9569, -7.7737, 7.4409, 0.7988,
    9.1016, -9.8816, 2.2430, 9.8905, -34.1429, 20.6593, 10.9414, -12.3863,
    24.0922, -3.1473, 7.4772, 1.7031, 2.7787, -1.5789};

/// Weight of the PCA normal in the final normal of a candidate.
double blend_weight(const std::array<double, kMfpsBlendFeatures>& f) {
  double z = 0;
  int term = 0;
  for (int a = 0; a < kMfpsBlendFeatures; ++a) z += kBlendCoefficients[size_t(term++)] * f[size_t(a)];
  for (int a = 1; a < kMfpsBlendFeatures; ++a)
    for (int b = a; b < kMfpsBlendFeatures; ++b)
      z += kBlendCoefficients[size_t(term++)] * f[size_t(a)] * f[size_t(b)];
  return 1.0 / (1.0 + std::exp(-std::clamp(z, -50.0, 50.0)));
}

/// Unoriented angle between unit vectors, radians.
double line_angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.dot(b))));
}

/// Rotates unit `a` towards unit `b` (sign-aligned) by fraction t of the angle between them.
Eigen::Vector3d slerp_towards(const Eigen::Vector3d& a, Eigen::Vector3d b, double t) {
  if (b.dot(a) < 0) b = -b;
  const double theta = std::acos(std::clamp(a.dot(b), -1.0, 1.0));
  if (!(theta > 1e-9)) return a;
  const Eigen::Vector3d v = (std::sin((1 - t) * theta) * a + std::sin(t * theta) * b) / std::sin(theta);
  return v.allFinite() && v.norm() > 0.5 ? Eigen::Vector3d(v.normalized()) : a;
}

/// 1 - mean |n_i . n_j| over the first `k` neighbours of row i (self included).
double inconsistency(const Normals& normals, const IndexMatrix& knn, Eigen::Index i, int k) {
  const int kk = int(std::min<Eigen::Index>(k, knn.cols()));
  const Eigen::Vector3d ni = normals.row(i).transpose();
  double sum = 0;
  int used = 0;
  for (int t = 0; t < kk; ++t) {
    const Eigen::Vector3d nj = normals.row(knn(i, t)).transpose();
    if (!nj.allFinite()) continue;
    sum += std::abs(ni.dot(nj));
    ++used;
  }
  return used ? 1.0 - sum / used : 0.0;
}

}  // namespace

MfpsResult mfps_normals(const Points& points, const IndexMatrix& knn, const Eigen::VectorXd& sigma,
                        const std::vector<uint8_t>& candidate, const Normals& base_normals,
                        const MfpsOptions& options, const RunContext& run) {
  const Eigen::Index n = points.rows();
  if (knn.rows() != n || sigma.size() != n || Eigen::Index(candidate.size()) != n ||
      base_normals.rows() != n)
    throw InvalidOptions("mfps_normals: inputs must have one row per point");
  if (options.scales.empty()) throw InvalidOptions("mfps: at least one scale is needed");
  std::vector<int> scales = options.scales;
  std::sort(scales.begin(), scales.end());
  scales.erase(std::unique(scales.begin(), scales.end()), scales.end());
  for (int& k : scales) k = int(std::min<Eigen::Index>(k, knn.cols()));
  scales.erase(std::unique(scales.begin(), scales.end()), scales.end());
  if (scales.front() < 4) throw InvalidOptions("mfps: scales must be at least 4");
  if (options.samples < 1) throw InvalidOptions("mfps: samples must be >= 1");
  const int ns = int(scales.size());
  const int kmin = scales.front(), kmax = scales.back();
  auto eta = [&](int k) {
    return kmax == kmin ? 1.0
                        : options.alpha + (1 - options.alpha) * double(k - kmin) / double(kmax - kmin);
  };

  MfpsResult res;
  res.normals = base_normals;
  res.chosen_scale.assign(size_t(n), 0);

  // Patches that contain at least one candidate, per scale: a patch at scale s contains a
  // candidate iff one of its first K members is one. first_cand[j] = column of the first
  // candidate in row j (or a large number).
  std::vector<int> first_cand(size_t(n), std::numeric_limits<int>::max());
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index t = 0; t < std::min<Eigen::Index>(kmax, knn.cols()); ++t)
      if (candidate[size_t(knn(j, t))]) {
        first_cand[size_t(j)] = int(t);
        break;
      }

  // Phase 1 (Eq. 1-2): the plane of every patch that contains a candidate.
  std::vector<Eigen::Vector3f> plane_n(size_t(n) * ns, Eigen::Vector3f::Zero());
  std::vector<Eigen::Vector3d> plane_c(size_t(n) * ns, Eigen::Vector3d::Zero());
  std::vector<double> plane_e(size_t(n) * ns, -1.0);
  std::atomic<int64_t> fallbacks{0}, patches{0};
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("mfps planes", 0, 0.9);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t j) {
    if (first_cand[size_t(j)] == std::numeric_limits<int>::max()) return;
    thread_local std::vector<Eigen::Vector3d> q;
    thread_local std::vector<double> w;
    thread_local std::vector<int> subset;
    thread_local std::vector<std::pair<double, int>> scored;
    thread_local std::vector<Plane> cands;
    thread_local std::vector<double> best_w, next_w;  // kernels of `best` / of a new plane
    const Eigen::Vector3d pj = points.row(j).transpose();
    const double sj = sigma[j];
    const double inv_s2 = 1.0 / (sj * sj);
    for (int s = 0; s < ns; ++s) {
      const int K = scales[size_t(s)];
      if (first_cand[size_t(j)] >= K) continue;
      patches.fetch_add(1, std::memory_order_relaxed);
      q.resize(size_t(K));
      for (int t = 0; t < K; ++t) q[size_t(t)] = points.row(knn(j, t)).transpose() - pj;
      // Every patch of a scale draws the same sequence of neighbour ranks: its planes then depend
      // only on its members and their distance order, so MFPS is invariant to rotation,
      // translation, scale and point order (a seed from the point index is not: the core
      // processes points in a coordinate-sorted order), and independent of scheduling.
      SplitMix rng{options.seed * 0x9E3779B97F4A7C15ull ^ uint64_t(K)};
      // Scoring subset: the centre plus random members (all when score_subset is 0 or >= K).
      const std::vector<int>* sub = nullptr;
      if (options.score_subset > 0 && options.score_subset < K) {
        subset.clear();
        subset.push_back(0);
        for (int t = 1; t < K; ++t) subset.push_back(t);
        for (int t = 1; t < options.score_subset; ++t)
          std::swap(subset[size_t(t)], subset[size_t(t + rng.below(K - t))]);
        subset.resize(size_t(options.score_subset));
        sub = &subset;
      }
      scored.clear();
      cands.clear();
      for (int m = 0; m < options.samples; ++m) {
        int a = 1 + rng.below(K - 1), b = 1 + rng.below(K - 1), c = 1 + rng.below(K - 1);
        for (int guard = 0; (b == a) && guard < 8; ++guard) b = 1 + rng.below(K - 1);
        for (int guard = 0; (c == a || c == b) && guard < 8; ++guard) c = 1 + rng.below(K - 1);
        if (a == b || a == c || b == c) continue;
        Plane pl;
        if (!four_point_plane(q[0], q[size_t(a)], q[size_t(b)], q[size_t(c)], pl)) continue;
        const double r0 = (q[0] - pl.c).dot(pl.n);
        if (r0 * r0 > sj * sj) continue;  // the plane must pass near the patch centre
        scored.emplace_back(objective(q, pl, inv_s2, sub), int(cands.size()));
        cands.push_back(pl);
      }
      Plane best;
      double best_e = -1;
      best_w.resize(size_t(K));
      next_w.resize(size_t(K));
      bool have_w = false;  // best_w holds the kernels of `best`
      if (scored.empty()) {
        // Every sample rejected: fall back to the least-squares plane of the whole patch.
        w.assign(size_t(K), 1.0);
        if (!weighted_plane(q, w.data(), best)) continue;
        best_e = objective(q, best, inv_s2, nullptr, best_w.data());
        have_w = true;
        fallbacks.fetch_add(1, std::memory_order_relaxed);
      } else {
        const size_t keep = std::min(scored.size(), size_t(std::max(1, options.rescore)));
        std::partial_sort(scored.begin(), scored.begin() + long(keep), scored.end(),
                          [](const auto& x, const auto& y) {
                            return x.first > y.first || (x.first == y.first && x.second < y.second);
                          });
        for (size_t t = 0; t < keep; ++t) {
          const Plane& pl = cands[size_t(scored[t].second)];
          const double e = sub ? objective(q, pl, inv_s2, nullptr, next_w.data()) : scored[t].first;
          if (e > best_e) {
            best_e = e;
            best = pl;
            if (sub) best_w.swap(next_w);
            have_w = sub != nullptr;
          }
        }
      }
      // IRLS: weighted PCA with the Gaussian weights of the current plane increases E.
      for (int it = 0; it < options.refine_iterations; ++it) {
        if (!have_w) {
          objective(q, best, inv_s2, nullptr, best_w.data());
          have_w = true;
        }
        Plane next;
        if (!weighted_plane(q, best_w.data(), next)) break;
        const double e = objective(q, next, inv_s2, nullptr, next_w.data());
        if (!(e > best_e)) break;
        best_e = e;
        best = next;
        best_w.swap(next_w);
      }
      const size_t slot = size_t(j) * size_t(ns) + size_t(s);
      plane_n[slot] = best.n.cast<float>();
      plane_c[slot] = best.c + pj;
      plane_e[slot] = best_e;
    }
  });
  res.fallback_patches = fallbacks.load();
  res.patches = patches.load();

  // Phase 2 (Eq. 3-4): every candidate keeps the best-scoring patch that contains it. Each
  // thread scans a share of the patches; ties go to the lower patch id so the result does not
  // depend on the thread count.
  std::vector<int32_t> cand_id(size_t(n), -1);
  int32_t nc = 0;
  for (Eigen::Index i = 0; i < n; ++i)
    if (candidate[size_t(i)]) cand_id[size_t(i)] = nc++;
  const int nt = detail::thread_count(run.threads);
  std::vector<std::vector<double>> best_score(size_t(nt), std::vector<double>(size_t(nc), -1.0));
  std::vector<std::vector<int64_t>> best_slot(size_t(nt), std::vector<int64_t>(size_t(nc), -1));
  // Calls visit(c, slot, normal, D) for every candidate c in every planed patch centred at j,
  // with D = E * exp(-r_c^2 / sigma_c^2) * eta(K) of Eq. 4.
  auto for_each_score = [&](int64_t j, auto&& visit) {
    for (int s = 0; s < ns; ++s) {
      const size_t slot = size_t(j) * size_t(ns) + size_t(s);
      if (plane_e[slot] < 0) continue;
      const Eigen::Vector3d nrm = plane_n[slot].cast<double>();
      const double e = plane_e[slot] * eta(scales[size_t(s)]);
      for (int t = 0; t < scales[size_t(s)]; ++t) {
        const int32_t i = knn(j, t);
        const int32_t c = cand_id[size_t(i)];
        if (c < 0) continue;
        const double r = (points.row(i).transpose() - plane_c[slot]).dot(nrm);
        const double si = sigma[i] * options.point_sigma_factor;
        visit(c, int64_t(slot), nrm, e * std::exp(-r * r / (si * si)));
      }
    }
  };
  if (run.progress) progress.stage("mfps selection", 0.9, 1.0);
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t j = 0; j < int64_t(n); ++j) {
    auto& bs = best_score[size_t(omp_get_thread_num())];
    auto& bp = best_slot[size_t(omp_get_thread_num())];
    for_each_score(j, [&](int32_t c, int64_t slot, const Eigen::Vector3d&, double score) {
      if (score > bs[size_t(c)] || (score == bs[size_t(c)] && slot < bp[size_t(c)])) {
        bs[size_t(c)] = score;
        bp[size_t(c)] = slot;
      }
    });
  }
  // Merges the per-thread maxima; ties go to the lower slot.
  auto reduce = [&](std::vector<double>& score_out, std::vector<int64_t>& slot_out) {
    for (int32_t c = 0; c < nc; ++c) {
      for (int t = 0; t < nt; ++t) {
        const double sc = best_score[size_t(t)][size_t(c)];
        const int64_t sl = best_slot[size_t(t)][size_t(c)];
        if (sl >= 0 && (sc > score_out[size_t(c)] ||
                        (sc == score_out[size_t(c)] && sl < slot_out[size_t(c)]))) {
          score_out[size_t(c)] = sc;
          slot_out[size_t(c)] = sl;
        }
      }
    }
  };
  std::vector<double> best_all(size_t(nc), -1.0);
  std::vector<int64_t> slot_all(size_t(nc), -1);
  reduce(best_all, slot_all);
  // Two-face posterior (see mfps.hpp): the best patch among those whose plane differs from the
  // winner's by more than `rival_angle_deg`, found with the same deterministic reduction.
  const bool blend = options.posterior_beta > 0 || options.edge_sigma_factor > 0;
  const double cos_rival = std::cos(options.rival_angle_deg * M_PI / 180.0);
  std::vector<double> rival_all(size_t(nc), -1.0);
  std::vector<int64_t> rival_slot(size_t(nc), -1);
  if (blend) {
    for (int t = 0; t < nt; ++t) {
      std::fill(best_score[size_t(t)].begin(), best_score[size_t(t)].end(), -1.0);
      std::fill(best_slot[size_t(t)].begin(), best_slot[size_t(t)].end(), int64_t(-1));
    }
#pragma omp parallel for schedule(static) num_threads(nt)
    for (int64_t j = 0; j < int64_t(n); ++j) {
      auto& bs = best_score[size_t(omp_get_thread_num())];
      auto& bp = best_slot[size_t(omp_get_thread_num())];
      for_each_score(j, [&](int32_t c, int64_t slot, const Eigen::Vector3d& nrm, double score) {
        const int64_t win = slot_all[size_t(c)];
        if (win < 0 || std::abs(double(plane_n[size_t(win)].cast<double>().dot(nrm))) > cos_rival)
          return;
        if (score > bs[size_t(c)] || (score == bs[size_t(c)] && slot < bp[size_t(c)])) {
          bs[size_t(c)] = score;
          bp[size_t(c)] = slot;
        }
      });
    }
    reduce(rival_all, rival_slot);
  }
  // Candidates with a rival, and their blend features (all but the two neighbourhood ones,
  // which need every point's final normal first).
  const bool want_features = options.pca_blend || options.record_blend_features;
  std::vector<int64_t> blended_rows;
  std::vector<std::array<double, kMfpsBlendFeatures>> features;
  for (Eigen::Index i = 0; i < n; ++i) {
    const int32_t c = cand_id[size_t(i)];
    if (c < 0) continue;
    const int64_t slot = slot_all[size_t(c)];
    if (slot < 0) continue;  // no patch (only when every patch containing it was degenerate)
    Eigen::Vector3d nrm = plane_n[size_t(slot)].cast<double>().normalized();
    const Eigen::Vector3d winner = nrm;
    const int64_t rs = blend ? rival_slot[size_t(c)] : -1;
    if (rs >= 0 && best_all[size_t(c)] > 0 && rival_all[size_t(c)] > 0) {
      // P(rival) from the score ratio; rotating the winner towards the rival by P(rival) times
      // the angle between them minimises the expected squared angle error.
      Eigen::Vector3d n2 = plane_n[size_t(rs)].cast<double>().normalized();
      if (n2.dot(nrm) < 0) n2 = -n2;
      double p2 =
          1.0 / (1.0 + std::pow(best_all[size_t(c)] / rival_all[size_t(c)], options.posterior_beta));
      const double p_score = p2;
      double geo = -1, line_distance = std::numeric_limits<double>::infinity();
      if (options.edge_sigma_factor > 0) {
        const double s = options.edge_sigma_factor * sigma[i];
        geo = edge_posterior(points.row(i).transpose(), nrm, plane_c[size_t(slot)], n2,
                             plane_c[size_t(rs)], s, &line_distance);
        if (geo >= 0) p2 = p2 * geo / (p2 * geo + (1 - p2) * (1 - geo));
      }
      nrm = slerp_towards(nrm, n2, p2);
      if (want_features) {
        const Eigen::Vector3d pca = base_normals.row(i).transpose();
        const double theta = line_angle(winner, n2);
        const double a_pca_win = line_angle(pca, winner);
        std::array<double, kMfpsBlendFeatures> f{};
        f[0] = 1;                                   // intercept
        f[1] = 4 * p2 * (1 - p2);                   // uncertainty of the final posterior
        f[2] = theta;                               // winner-rival angle (rad)
        f[3] = line_angle(pca, nrm);                // PCA vs this normal (rad)
        f[4] = std::min(line_distance / (0.5 * sigma[i]), 10.0) / 10;  // to the edge line
        f[5] = 4 * p_score * (1 - p_score);         // uncertainty of the score posterior
        f[6] = geo >= 0 ? std::abs(2 * geo - 1) : 0;  // confidence of the edge posterior
        f[7] = a_pca_win + line_angle(pca, n2) - theta;  // PCA off the winner-rival arc (rad)
        f[10] = std::log(std::max(best_all[size_t(c)], 1e-6));  // winner's score D (Eq. 4)
        f[11] = a_pca_win;                          // PCA vs winner (rad)
        for (double& v : f)
          if (!std::isfinite(v)) v = 0;
        blended_rows.push_back(i);
        features.push_back(f);
      }
    }
    res.normals.row(i) = nrm.transpose();
    res.chosen_scale[size_t(i)] = scales[size_t(slot % ns)];
  }
  if (want_features) {
    // The neighbourhood features read the normals before any blending (all of them first, then
    // the blend), so the result does not depend on the order in which points are blended.
    for (size_t t = 0; t < blended_rows.size(); ++t) {
      const Eigen::Index i = blended_rows[t];
      features[t][8] = inconsistency(res.normals, knn, i, kBlendNeighbours);
      features[t][9] = inconsistency(base_normals, knn, i, kBlendNeighbours);
    }
    if (options.record_blend_features) {
      res.unblended_normals = res.normals;
      res.blend_features.resize(Eigen::Index(features.size()), kMfpsBlendFeatures);
      for (size_t t = 0; t < features.size(); ++t)
        for (int q = 0; q < kMfpsBlendFeatures; ++q) res.blend_features(Eigen::Index(t), q) = features[t][size_t(q)];
    }
    if (options.pca_blend)
      for (size_t t = 0; t < blended_rows.size(); ++t) {
        const Eigen::Index i = blended_rows[t];
        res.normals.row(i) = slerp_towards(res.normals.row(i).transpose(),
                                           base_normals.row(i).transpose(), blend_weight(features[t]))
                                 .transpose();
      }
    if (options.record_blend_features) res.blend_rows = std::move(blended_rows);
  }
  if (run.progress) {
    progress.report(1.0);
    progress.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
