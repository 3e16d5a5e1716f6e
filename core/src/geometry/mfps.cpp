// Multi-scale fitting patch selection: paper Eq. 1-4 (Sec. 4.1-4.2). See mfps.hpp for the
// choices the paper leaves open. mfps_normals runs the steps in order:
//   fit_patch_planes  Eq. 1-2  the plane theta* of every patch that contains a candidate
//   select_patches    Eq. 3-4  every candidate's best patch, and with a posterior its rival
//   choose_normals             the winner's normal, or the two-face / edge posterior's
//   blend_towards_pca          the PCA blend (not the paper's; mfps_blend.cpp)
#include "nhnet/geometry/mfps.hpp"

#include "geometry/mfps_blend.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "util/fast_math.hpp"
#include "util/parallel.hpp"
#include "util/spread.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <utility>

namespace nhnet {

namespace {

/// splitmix64: small, fast, good enough to draw sample indices (seeded per scale, see fit_patch)
/// so results do not depend on scheduling.
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

/// Points as three coordinate arrays (detail::plane_kernels' input).
struct Coords {
  std::vector<double> x, y, z;
  size_t size() const { return x.size(); }
  void resize(size_t m) {
    x.resize(m);
    y.resize(m);
    z.resize(m);
  }
  Eigen::Vector3d at(size_t t) const { return {x[t], y[t], z[t]}; }
  void set(size_t t, const Eigen::Vector3d& p) {
    x[t] = p[0];
    y[t] = p[1];
    z[t] = p[2];
  }
};

/// Least-squares plane of weighted patch-local points; false when degenerate.
bool weighted_plane(const Coords& q, const double* w, Plane& out) {
  double ws = 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < q.size(); ++k) {
    ws += w[k];
    c += w[k] * q.at(k);
  }
  if (!(ws > 0)) return false;
  c /= ws;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < q.size(); ++k) {
    const Eigen::Vector3d d = q.at(k) - c;
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

/// E of Eq. 1 (mean Gaussian kernel of residuals) over the points `q`. With `terms`, the
/// kernel of every point is stored there too: over a whole patch they are the IRLS weights of
/// that plane, so the refinement does not recompute them.
double objective(const Coords& q, const Plane& pl, double inv_s2, double* terms = nullptr) {
  thread_local std::vector<double> own;
  const size_t m = q.size();
  if (!terms) {
    own.resize(m);
    terms = own.data();
  }
  detail::plane_kernels(q.x.data(), q.y.data(), q.z.data(), m, pl.c.data(), pl.n.data(), inv_s2,
                        terms);
  double e = 0;
  for (size_t t = 0; t < m; ++t) e += terms[t];
  return e / double(m);
}

/// P(point p lies on face B) for two faces meeting at the edge line of planes (n1, c1) and
/// (n2, c2), each face being the half-plane on the side of its centre c; noise std s. Returns
/// -1 when the planes are (nearly) parallel. `line_distance` (when given and the planes meet)
/// receives the distance from p to the edge line.
double edge_posterior(const Eigen::Vector3d& p, const Eigen::Vector3d& n1,
                      const Eigen::Vector3d& c1, const Eigen::Vector3d& n2,
                      const Eigen::Vector3d& c2, double s, double* line_distance = nullptr) {
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
/// The arguments of mfps_normals.
struct Inputs {
  const Points& points;
  const IndexMatrix& knn;
  const Eigen::VectorXd& sigma;
  const std::vector<uint8_t>& candidate;
  const Normals& base_normals;
  const MfpsOptions& options;
};

/// The patch sizes K in use, and eta(K) of Eq. 4.
struct Scales {
  /// Ascending, unique, capped at the width of the neighbour table.
  std::vector<int> k;
  double alpha = 0.9;

  /// eta(K) = alpha + (1 - alpha) (K - Kmin) / (Kmax - Kmin) (1 with a single scale).
  double eta(int K) const {
    const int kmin = k.front(), kmax = k.back();
    return kmax == kmin ? 1.0 : alpha + (1 - alpha) * double(K - kmin) / double(kmax - kmin);
  }
};

/// Checks the inputs and options (throws InvalidOptions); returns the scales in use.
Scales checked_scales(const Inputs& in) {
  const Eigen::Index n = in.points.rows();
  if (in.knn.rows() != n || in.sigma.size() != n || Eigen::Index(in.candidate.size()) != n ||
      in.base_normals.rows() != n)
    throw InvalidOptions("mfps_normals: inputs must have one row per point");
  if (in.options.scales.empty()) throw InvalidOptions("mfps: at least one scale is needed");
  std::vector<int> scales = in.options.scales;
  std::sort(scales.begin(), scales.end());
  scales.erase(std::unique(scales.begin(), scales.end()), scales.end());
  for (int& k : scales) k = int(std::min<Eigen::Index>(k, in.knn.cols()));
  scales.erase(std::unique(scales.begin(), scales.end()), scales.end());
  if (scales.front() < 4) throw InvalidOptions("mfps: scales must be at least 4");
  if (in.options.samples < 1) throw InvalidOptions("mfps: samples must be >= 1");
  if (in.options.fit_members != 0 && in.options.fit_members < 4)
    throw InvalidOptions("mfps: fit_members must be 0 (all members) or at least 4");
  return Scales{std::move(scales), in.options.alpha};
}

/// Column of the first candidate in every row of `knn` (or a large number): the patch of size K
/// centred at j contains a candidate iff one of its first K members is one, i.e. column < K.
std::vector<int> first_candidate_columns(const Inputs& in, int kmax) {
  const Eigen::Index n = in.points.rows();
  std::vector<int> first_cand(size_t(n), std::numeric_limits<int>::max());
  for (Eigen::Index j = 0; j < n; ++j)
    for (Eigen::Index t = 0; t < std::min<Eigen::Index>(kmax, in.knn.cols()); ++t)
      if (in.candidate[size_t(in.knn(j, t))]) {
        first_cand[size_t(j)] = int(t);
        break;
      }
  return first_cand;
}

// ---- Eq. 1-2: the plane theta* of each patch

/// The plane of every patch, at slot j * ns + s (the patch of scale s centred at point j).
struct PatchPlanes {
  int ns = 0;
  /// Unit normal, a point on the plane (cloud coordinates), E of Eq. 1 (-1: no plane).
  std::vector<Eigen::Vector3f> n;
  std::vector<Eigen::Vector3d> c;
  std::vector<double> e;
  /// Patches whose plane was computed, and those of them that fell back to the PCA plane.
  int64_t patches = 0, fallbacks = 0;

  PatchPlanes(Eigen::Index points, int scales)
      : ns(scales),
        n(size_t(points) * scales, Eigen::Vector3f::Zero()),
        c(size_t(points) * scales, Eigen::Vector3d::Zero()),
        e(size_t(points) * scales, -1.0) {}
  size_t slot(int64_t j, int s) const { return size_t(j) * size_t(ns) + size_t(s); }
};

/// One thread's buffers for fitting patches, reused from patch to patch.
struct PatchScratch {
  Coords all;                                  // members relative to the centre, nearest first
  Coords scoring;                              // the members of the preemptive scoring
  std::vector<double> w;                       // unit weights of the fallback plane
  std::vector<int> subset;                     // members of the preemptive scoring
  std::vector<std::pair<double, int>> scored;  // (E on the subset, index in `cands`)
  std::vector<Plane> cands;                    // sampled planes that pass near the centre
  std::vector<double> best_w, next_w;          // kernels of `best` / of a new plane
};

/// The plane being fitted to one patch.
struct PatchFit {
  Plane best;
  double e = -1;          // E of Eq. 1 of `best` on the whole patch
  bool have_w = false;    // PatchScratch::best_w holds the kernels of `best`
  bool fallback = false;  // every sample was rejected
};

/// Members of the preemptive scoring of a patch of K: the centre plus `size` - 1 random members,
/// copied to ps.scoring (null: all members, when size is 0 or >= K).
const std::vector<int>* draw_score_subset(SplitMix& rng, int K, int size, PatchScratch& ps) {
  if (!(size > 0 && size < K)) return nullptr;
  std::vector<int>& subset = ps.subset;
  subset.clear();
  subset.push_back(0);
  for (int t = 1; t < K; ++t) subset.push_back(t);
  for (int t = 1; t < size; ++t) std::swap(subset[size_t(t)], subset[size_t(t + rng.below(K - t))]);
  subset.resize(size_t(size));
  ps.scoring.resize(size_t(size));
  for (size_t t = 0; t < size_t(size); ++t) ps.scoring.set(t, ps.all.at(size_t(subset[t])));
  return &subset;
}

/// `samples` random planes through the centre and 3 other members, scored by E (Eq. 1) on the
/// members `scoring`; a plane that misses the centre by more than sigma_j is rejected.
void sample_planes(PatchScratch& ps, const Coords& scoring, SplitMix& rng, int K, int samples,
                   double sj, double inv_s2) {
  const Coords& q = ps.all;
  ps.scored.clear();
  ps.cands.clear();
  for (int m = 0; m < samples; ++m) {
    int a = 1 + rng.below(K - 1), b = 1 + rng.below(K - 1), c = 1 + rng.below(K - 1);
    for (int guard = 0; (b == a) && guard < 8; ++guard) b = 1 + rng.below(K - 1);
    for (int guard = 0; (c == a || c == b) && guard < 8; ++guard) c = 1 + rng.below(K - 1);
    if (a == b || a == c || b == c) continue;
    Plane pl;
    if (!four_point_plane(q.at(0), q.at(size_t(a)), q.at(size_t(b)), q.at(size_t(c)), pl)) continue;
    const double r0 = (q.at(0) - pl.c).dot(pl.n);
    if (r0 * r0 > sj * sj) continue;  // the plane must pass near the patch centre
    ps.scored.emplace_back(objective(scoring, pl, inv_s2), int(ps.cands.size()));
    ps.cands.push_back(pl);
  }
}

/// Every sample rejected: the least-squares plane of the whole patch; false when degenerate.
bool fallback_plane(PatchScratch& ps, int K, double inv_s2, PatchFit& fit) {
  ps.w.assign(size_t(K), 1.0);
  if (!weighted_plane(ps.all, ps.w.data(), fit.best)) return false;
  fit.e = objective(ps.all, fit.best, inv_s2, ps.best_w.data());
  fit.have_w = true;
  fit.fallback = true;
  return true;
}

/// Re-scores the `rescore` best samples by E (Eq. 1) on the whole patch and keeps the best
/// (ties to the earlier sample); without a scoring subset their scores are already that E.
void rescore_best(PatchScratch& ps, int rescore, double inv_s2, const std::vector<int>* sub,
                  PatchFit& fit) {
  const size_t keep = std::min(ps.scored.size(), size_t(std::max(1, rescore)));
  std::partial_sort(ps.scored.begin(), ps.scored.begin() + long(keep), ps.scored.end(),
                    [](const auto& x, const auto& y) {
                      return x.first > y.first || (x.first == y.first && x.second < y.second);
                    });
  for (size_t t = 0; t < keep; ++t) {
    const Plane& pl = ps.cands[size_t(ps.scored[t].second)];
    const double e = sub ? objective(ps.all, pl, inv_s2, ps.next_w.data()) : ps.scored[t].first;
    if (e > fit.e) {
      fit.e = e;
      fit.best = pl;
      if (sub) ps.best_w.swap(ps.next_w);
      fit.have_w = sub != nullptr;
    }
  }
}

/// IRLS towards theta* of Eq. 2: weighted PCA with the Gaussian weights of the current plane
/// increases E; stops when E no longer grows.
void refine_irls(PatchScratch& ps, int iterations, double inv_s2, PatchFit& fit) {
  for (int it = 0; it < iterations; ++it) {
    if (!fit.have_w) {
      objective(ps.all, fit.best, inv_s2, ps.best_w.data());
      fit.have_w = true;
    }
    Plane next;
    if (!weighted_plane(ps.all, ps.best_w.data(), next)) break;
    const double e = objective(ps.all, next, inv_s2, ps.next_w.data());
    if (!(e > fit.e)) break;
    fit.e = e;
    fit.best = next;
    ps.best_w.swap(ps.next_w);
  }
}

/// theta* of one patch of K members (in ps.all), Eq. 1-2: random 4-point samples, preemptive
/// scoring, re-scoring of the best, IRLS refinement. False when the patch has no plane.
bool fit_patch(PatchScratch& ps, int K, double sj, const MfpsOptions& options, PatchFit& fit) {
  const double inv_s2 = 1.0 / (sj * sj);
  // Every patch of a scale draws the same sequence of neighbour ranks: its planes then depend
  // only on its members and their distance order, so MFPS is invariant to rotation,
  // translation, scale and point order (a seed from the point index is not: the core
  // processes points in a coordinate-sorted order), and independent of scheduling.
  SplitMix rng{options.seed * 0x9E3779B97F4A7C15ull ^ uint64_t(K)};
  const std::vector<int>* sub = draw_score_subset(rng, K, options.score_subset, ps);
  sample_planes(ps, sub ? ps.scoring : ps.all, rng, K, options.samples, sj, inv_s2);
  ps.best_w.resize(size_t(K));
  ps.next_w.resize(size_t(K));
  if (ps.scored.empty()) {
    if (!fallback_plane(ps, K, inv_s2, fit)) return false;
  } else {
    rescore_best(ps, options.rescore, inv_s2, sub, fit);
  }
  refine_irls(ps, options.refine_iterations, inv_s2, fit);
  return true;
}

/// Eq. 1-2 for every patch that contains a candidate (`first_cand`), in parallel.
PatchPlanes fit_patch_planes(const Inputs& in, const Scales& scales,
                             const std::vector<int>& first_cand, const RunContext& run,
                             detail::Progress& progress) {
  const Eigen::Index n = in.points.rows();
  PatchPlanes planes(n, int(scales.k.size()));
  std::atomic<int64_t> fallbacks{0}, patches{0};
  if (run.progress) progress.stage("mfps planes", 0, 0.9);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t j) {
    if (first_cand[size_t(j)] == std::numeric_limits<int>::max()) return;
    thread_local PatchScratch ps;
    const Eigen::Vector3d pj = in.points.row(j).transpose();
    for (int s = 0; s < planes.ns; ++s) {
      const int K = scales.k[size_t(s)];
      if (first_cand[size_t(j)] >= K) continue;
      patches.fetch_add(1, std::memory_order_relaxed);
      const int m = detail::spread_count(K, in.options.fit_members);
      ps.all.resize(size_t(m));
      for (int t = 0; t < m; ++t)
        ps.all.set(size_t(t),
                   in.points.row(in.knn(j, detail::spread_rank(t, m, K))).transpose() - pj);
      PatchFit fit;
      if (!fit_patch(ps, m, in.sigma[j], in.options, fit)) continue;
      if (fit.fallback) fallbacks.fetch_add(1, std::memory_order_relaxed);
      const size_t slot = planes.slot(j, s);
      planes.n[slot] = fit.best.n.cast<float>();
      planes.c[slot] = fit.best.c + pj;
      planes.e[slot] = fit.e;
    }
  });
  planes.fallbacks = fallbacks.load();
  planes.patches = patches.load();
  return planes;
}

// ---- Eq. 3-4: every candidate's best patch

/// Numbers the candidates in row order: id[i] = candidate number of point i, -1 elsewhere.
std::vector<int32_t> number_candidates(const std::vector<uint8_t>& candidate, int32_t& count) {
  std::vector<int32_t> id(candidate.size(), -1);
  count = 0;
  for (size_t i = 0; i < candidate.size(); ++i)
    if (candidate[i]) id[i] = count++;
  return id;
}

/// D of Eq. 4 for the candidates of the patches centred at one point.
struct PatchScorer {
  const Inputs& in;
  const Scales& scales;
  const PatchPlanes& planes;
  const std::vector<int32_t>& cand_id;

  /// Calls visit(c, slot, normal, D) for every candidate c in every planed patch centred at j,
  /// with D = E * exp(-r_c^2 / sigma_c^2) * eta(K) of Eq. 4.
  template <class Visit>
  void for_each_score(int64_t j, Visit&& visit) const {
    for (int s = 0; s < planes.ns; ++s) {
      const size_t slot = planes.slot(j, s);
      if (planes.e[slot] < 0) continue;
      const Eigen::Vector3d nrm = planes.n[slot].cast<double>();
      const double e = planes.e[slot] * scales.eta(scales.k[size_t(s)]);
      for (int t = 0; t < scales.k[size_t(s)]; ++t) {
        const int32_t i = in.knn(j, t);
        const int32_t c = cand_id[size_t(i)];
        if (c < 0) continue;
        const double r = (in.points.row(i).transpose() - planes.c[slot]).dot(nrm);
        const double si = in.sigma[i] * in.options.point_sigma_factor;
        visit(c, int64_t(slot), nrm, e * std::exp(-r * r / (si * si)));
      }
    }
  }
};

/// Merges per-thread maxima (score, slot) per candidate into `score` / `slot`; ties go to the
/// lower slot, so the result does not depend on the thread count.
void merge_thread_maxima(const std::vector<std::vector<double>>& best_score,
                         const std::vector<std::vector<int64_t>>& best_slot,
                         std::vector<double>& score, std::vector<int64_t>& slot) {
  for (size_t c = 0; c < score.size(); ++c) {
    for (size_t t = 0; t < best_score.size(); ++t) {
      const double sc = best_score[t][c];
      const int64_t sl = best_slot[t][c];
      if (sl >= 0 && (sc > score[c] || (sc == score[c] && sl < slot[c]))) {
        score[c] = sc;
        slot[c] = sl;
      }
    }
  }
}

/// Per candidate, the patch of highest D (Eq. 4) among those containing it whose normal
/// accept(c, normal) admits; -1 / -1 where none. Each thread scans a share of the patches.
template <class Accept>
void best_patches(const PatchScorer& scorer, int nt, Accept&& accept, std::vector<double>& score,
                  std::vector<int64_t>& slot) {
  const size_t nc = score.size();
  std::vector<std::vector<double>> best_score(size_t(nt), std::vector<double>(nc, -1.0));
  std::vector<std::vector<int64_t>> best_slot(size_t(nt), std::vector<int64_t>(nc, -1));
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int64_t j = 0; j < int64_t(scorer.in.points.rows()); ++j) {
    auto& bs = best_score[size_t(omp_get_thread_num())];
    auto& bp = best_slot[size_t(omp_get_thread_num())];
    scorer.for_each_score(j, [&](int32_t c, int64_t sl, const Eigen::Vector3d& nrm, double d) {
      if (!accept(c, nrm)) return;
      if (d > bs[size_t(c)] || (d == bs[size_t(c)] && sl < bp[size_t(c)])) {
        bs[size_t(c)] = d;
        bp[size_t(c)] = sl;
      }
    });
  }
  merge_thread_maxima(best_score, best_slot, score, slot);
}

/// Per candidate: the winning patch (slot, score D) and the best rival patch; slots -1 where
/// none (a rival only with a posterior).
struct Selection {
  std::vector<double> best, rival;
  std::vector<int64_t> slot, rival_slot;
};

/// Eq. 3-4: every candidate's patch of highest D among all patches of all scales that contain
/// it; with a posterior also its rival, the best patch whose plane differs from the winner's
/// by more than rival_angle_deg.
Selection select_patches(const PatchScorer& scorer, int nt, int32_t nc) {
  const MfpsOptions& options = scorer.in.options;
  Selection sel{std::vector<double>(size_t(nc), -1.0), std::vector<double>(size_t(nc), -1.0),
                std::vector<int64_t>(size_t(nc), -1), std::vector<int64_t>(size_t(nc), -1)};
  best_patches(
      scorer, nt, [](int32_t, const Eigen::Vector3d&) { return true; }, sel.best, sel.slot);
  if (!(options.posterior_beta > 0 || options.edge_sigma_factor > 0)) return sel;
  const double cos_rival = std::cos(options.rival_angle_deg * M_PI / 180.0);
  const std::vector<Eigen::Vector3f>& plane_n = scorer.planes.n;
  auto is_rival = [&](int32_t c, const Eigen::Vector3d& nrm) {
    const int64_t win = sel.slot[size_t(c)];
    return !(win < 0 || std::abs(double(plane_n[size_t(win)].cast<double>().dot(nrm))) > cos_rival);
  };
  best_patches(scorer, nt, is_rival, sel.rival, sel.rival_slot);
  return sel;
}

// ---- The choice between winner and rival

/// Two-face posterior of a candidate (row i) whose winner (slot, score d1, unit normal
/// `winner`) has a rival (slot rs, score d2): P(rival) = 1 / (1 + (d1/d2)^beta), combined with
/// the edge posterior when on; the winner is rotated towards the rival by P(rival).
detail::TwoFaceChoice two_face_choice(const Inputs& in, const PatchPlanes& planes, Eigen::Index i,
                                      const Eigen::Vector3d& winner, int64_t slot, double d1,
                                      int64_t rs, double d2) {
  detail::TwoFaceChoice ch;
  ch.winner = winner;
  ch.score = d1;
  // P(rival) from the score ratio; rotating the winner towards the rival by P(rival) times
  // the angle between them minimises the expected squared angle error.
  ch.rival = planes.n[size_t(rs)].cast<double>().normalized();
  if (ch.rival.dot(winner) < 0) ch.rival = -ch.rival;
  ch.p = 1.0 / (1.0 + std::pow(d1 / d2, in.options.posterior_beta));
  ch.p_score = ch.p;
  if (in.options.edge_sigma_factor > 0) {
    const double s = in.options.edge_sigma_factor * in.sigma[i];
    ch.p_edge = edge_posterior(in.points.row(i).transpose(), winner, planes.c[size_t(slot)],
                               ch.rival, planes.c[size_t(rs)], s, &ch.line_distance);
    const double geo = ch.p_edge, p2 = ch.p;
    if (geo >= 0) ch.p = p2 * geo / (p2 * geo + (1 - p2) * (1 - geo));
  }
  ch.normal = detail::slerp_towards(winner, ch.rival, ch.p);
  return ch;
}

/// Whether the blend's features and weights are computed: to apply the blend or to report it.
bool wants_blend(const MfpsOptions& o) {
  return o.pca_blend || o.record_blend_features || o.keep_blend_weights;
}

/// Every candidate's normal and scale: its winner's plane (the paper's argmax), moved towards
/// its rival's by the two-face posterior where it has one; collects the blend features.
void choose_normals(const Inputs& in, const Scales& scales, const PatchPlanes& planes,
                    const std::vector<int32_t>& cand_id, const Selection& sel, MfpsResult& res,
                    detail::BlendCandidates& blend) {
  const bool want_features = wants_blend(in.options);
  for (Eigen::Index i = 0; i < in.points.rows(); ++i) {
    const int32_t c = cand_id[size_t(i)];
    if (c < 0) continue;
    const int64_t slot = sel.slot[size_t(c)];
    if (slot < 0) continue;  // no patch (only when every patch containing it was degenerate)
    Eigen::Vector3d nrm = planes.n[size_t(slot)].cast<double>().normalized();
    const int64_t rs = sel.rival_slot[size_t(c)];
    if (rs >= 0 && sel.best[size_t(c)] > 0 && sel.rival[size_t(c)] > 0) {
      const detail::TwoFaceChoice ch =
          two_face_choice(in, planes, i, nrm, slot, sel.best[size_t(c)], rs, sel.rival[size_t(c)]);
      nrm = ch.normal;
      if (want_features) {
        blend.rows.push_back(i);
        blend.features.push_back(
            detail::blend_features(ch, in.base_normals.row(i).transpose(), in.sigma[i]));
      }
    }
    res.normals.row(i) = nrm.transpose();
    res.chosen_scale[size_t(i)] = scales.k[size_t(slot % planes.ns)];
  }
}

}  // namespace

MfpsResult mfps_normals(const Points& points, const IndexMatrix& knn, const Eigen::VectorXd& sigma,
                        const std::vector<uint8_t>& candidate, const Normals& base_normals,
                        const MfpsOptions& options, const RunContext& run) {
  const Inputs in{points, knn, sigma, candidate, base_normals, options};
  const Scales scales = checked_scales(in);
  MfpsResult res;
  res.normals = base_normals;
  res.chosen_scale.assign(size_t(points.rows()), 0);
  detail::Progress progress(run.progress);

  // Eq. 1-2: the plane of every patch that contains a candidate.
  const PatchPlanes planes =
      fit_patch_planes(in, scales, first_candidate_columns(in, scales.k.back()), run, progress);
  res.fallback_patches = planes.fallbacks;
  res.patches = planes.patches;

  // Eq. 3-4: every candidate's best patch (and rival), then its normal.
  int32_t nc = 0;
  const std::vector<int32_t> cand_id = number_candidates(candidate, nc);
  if (run.progress) progress.stage("mfps selection", 0.9, 1.0);
  const PatchScorer scorer{in, scales, planes, cand_id};
  const Selection sel = select_patches(scorer, detail::thread_count(run.threads), nc);
  detail::BlendCandidates blend;
  choose_normals(in, scales, planes, cand_id, sel, res, blend);

  // Not the paper's: the PCA blend (mfps_blend.cpp).
  if (wants_blend(options))
    detail::blend_towards_pca(std::move(blend), knn, base_normals, options, res);
  if (run.progress) {
    progress.report(1.0);
    progress.throw_if_cancelled();
  }
  return res;
}

}  // namespace nhnet
