// Normal orientation (keep / viewpoint / MST, Hoppe et al. 1992, with a reflection criterion),
// see orient.hpp. The arrays never change order.
#include "nhnet/orient/orient.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "neighbors/dedupe.hpp"
#include "orient/inside_outside.hpp"
#include "util/parallel.hpp"
#include "util/stats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <queue>
#include <string>
#include <vector>

namespace nhnet {

OrientMode orient_mode_from_string(const std::string& name) {
  if (name == "none") return OrientMode::None;
  if (name == "keep") return OrientMode::Keep;
  if (name == "viewpoint") return OrientMode::Viewpoint;
  if (name == "mst") return OrientMode::Mst;
  throw InvalidOptions("unknown orientation '" + name + "' (expected keep, viewpoint, mst or none)");
}

const char* to_string(OrientMode mode) {
  switch (mode) {
    case OrientMode::None: return "none";
    case OrientMode::Keep: return "keep";
    case OrientMode::Viewpoint: return "viewpoint";
    case OrientMode::Mst: return "mst";
  }
  return "?";
}

namespace {

// A normal farther than acos(kOwnVoteCos) = 45 degrees from its guide takes its own side from
// the flood fill where that decides (couplingdown, MFPS normals: +0.1-0.2 points of correct
// signs; always using the own vote was no better).
constexpr double kOwnVoteCos = 0.7;
// A flood vote is dropped when its decided neighbours' consistency sums to below -kCleanup of
// their total weight (rotor: +0.1 points).
constexpr double kCleanup = 0.3;

bool valid_normal(const Eigen::RowVector3d& n) {
  const double len = n.norm();
  return std::isfinite(len) && len > 1e-12;
}

/// MST orientation (Hoppe et al. 1992) of the rows `used` of points/normals: Prim's algorithm on
/// the symmetric k-NN graph, one tree per connected component grown from its highest point, over
/// the guide normals (OrientOptions::smooth_guide); the signs then go to `normals`.
/// Returns for every entry of `used` whether it was oriented.
std::vector<uint8_t> orient_mst(const Points& points, Normals& normals,
                                const std::vector<int64_t>& used, const OrientOptions& options,
                                OrientResult& res) {
  const Eigen::Index m = Eigen::Index(used.size());
  if (m == 0) return {};
  detail::Progress progress(options.run.progress);
  Points pts(m, 3);
  Normals guide(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    pts.row(i) = points.row(used[size_t(i)]);
    guide.row(i) = normals.row(used[size_t(i)]).normalized();
  }

  // Symmetric k-NN graph (an edge when either point is among the other's k nearest, self
  // included), as adjacency lists.
  const int k = int(std::min<Eigen::Index>(options.k, m));
  if (options.run.progress) progress.stage("orient: neighbours", 0, 0.3);
  std::vector<std::vector<int32_t>> adj(static_cast<size_t>(m));
  double noise = 0;  // typical offset of a neighbour from a point's guide plane
  double spacing = 0;  // mean distance to the nearest other point (the flood fill's unit)
  double median_spacing = 0;  // its median (blind to a few far outliers)
  if (m > 1) {
    const Neighbors tree(pts);
    RunContext sub;
    sub.threads = options.run.threads;
    IndexMatrix knn;
    tree.knn_all(k, knn, nullptr, sub);
    int64_t counted = 0;
    std::vector<double> nearest_all;
    nearest_all.reserve(size_t(m));
    for (Eigen::Index i = 0; i < m; ++i) {
      double nearest = std::numeric_limits<double>::infinity();
      for (Eigen::Index c = 1; c < knn.cols(); ++c) {
        const int32_t j = knn(i, c);
        if (j == int32_t(i)) continue;
        adj[size_t(i)].push_back(j);
        adj[size_t(j)].push_back(int32_t(i));
        nearest = std::min(nearest, (pts.row(j) - pts.row(i)).norm());
      }
      if (std::isfinite(nearest)) {
        spacing += nearest;
        nearest_all.push_back(nearest);
        ++counted;
      }
    }
    if (counted > 0) spacing /= double(counted);
    median_spacing = detail::quantile(std::move(nearest_all), 0.5);
    for (auto& a : adj) {
      std::sort(a.begin(), a.end());
      a.erase(std::unique(a.begin(), a.end()), a.end());
    }
    if (options.smooth_guide && m >= 3) {
      IndexMatrix gknn;
      tree.knn_all(options.guide_k, gknn, nullptr, sub);
      const Normals pca = pca_normals(pts, gknn, PcaOptions{int(gknn.cols())}, sub).normals;
      for (Eigen::Index i = 0; i < m; ++i)
        if (pca.row(i).allFinite()) guide.row(i) = pca.row(i);
    }
    // Noise: the median over the points of the median offset |(p_j - p_i) . g_i| of their graph
    // neighbours (~0.95 sigma on a noisy plane); a median, so a wall's other side (a minority of
    // the k nearest) does not count.
    std::vector<double> typical;
    typical.reserve(size_t(m));
    std::vector<double> off;
    for (Eigen::Index i = 0; i < m; ++i) {
      off.clear();
      for (int32_t j : adj[size_t(i)])
        off.push_back(std::abs(guide.row(i).dot(pts.row(j) - pts.row(i))));
      if (off.empty()) continue;
      std::nth_element(off.begin(), off.begin() + off.size() / 2, off.end());
      typical.push_back(off[off.size() / 2]);
    }
    if (!typical.empty()) {
      std::nth_element(typical.begin(), typical.begin() + typical.size() / 2, typical.end());
      noise = typical[typical.size() / 2];
    }
  }
  progress.throw_if_cancelled();

  // Consistency of the pair (i, j): c_ij > 0 when the signs agree. Hoppe: g_i . g_j. Reflection
  // (OrientOptions::reflect): g_i mirrored at the bisecting plane of p_i p_j, dotted with g_j,
  //   c_ij = g_i . g_j - 2 (g_i . u)(g_j . u),  u = (p_j - p_i) / |p_j - p_i|,
  // which maps a normal exactly onto its neighbour's on a sphere, across a sharp edge (cube
  // faces: |c| = 1 where g_i . g_j = 0) and across a thin wall (opposite sides: c = +1 for
  // outward normals facing away from each other, where g_i . g_j = -1 would copy the sign).
  const bool reflect = options.reflect;
  auto consistency = [&](int32_t i, int32_t j) {
    const Eigen::RowVector3d gi = guide.row(i), gj = guide.row(j);
    double c = gi.dot(gj);
    if (reflect) {
      const Eigen::RowVector3d d = pts.row(j) - pts.row(i);
      const double len2 = d.squaredNorm();
      const double a = gi.dot(d), b = gj.dot(d);
      const double floor = options.reflect_noise * noise;
      if (len2 > 0 && std::min(a * a, b * b) >= options.reflect_min * options.reflect_min * len2 &&
          std::min(std::abs(a), std::abs(b)) > floor)
        c -= 2.0 * a * b / len2;
    }
    return c;
  };

  // Prim from the highest unvisited point (its guide turned to +z: outward on a closed surface);
  // each edge costs 1 - |c_ij|, so the sign travels along the most confident pairs.
  std::vector<int32_t> order(static_cast<size_t>(m));
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return pts(a, 2) > pts(b, 2); });
  std::vector<uint8_t> visited(static_cast<size_t>(m), 0);
  struct Edge {
    double cost;
    int32_t from, to;
    bool operator<(const Edge& o) const { return cost > o.cost; }  // min-heap
  };
  std::priority_queue<Edge> heap;
  if (options.run.progress) progress.stage("orient: mst", 0.3, 1.0);
  int64_t done = 0;
  auto visit = [&](int32_t u) {
    visited[size_t(u)] = 1;
    for (int32_t v : adj[size_t(u)])
      if (!visited[size_t(v)]) heap.push(Edge{1.0 - std::abs(consistency(u, v)), u, v});
    if ((++done & 4095) == 0 && options.run.progress && !progress.report(double(done) / double(m)))
      progress.throw_if_cancelled();
  };
  auto drain = [&](std::vector<int32_t>* members) {
    while (!heap.empty()) {
      const Edge e = heap.top();
      heap.pop();
      if (visited[size_t(e.to)]) continue;
      if (consistency(e.from, e.to) < 0) guide.row(e.to) *= -1.0;
      if (members) members->push_back(e.to);
      visit(e.to);
    }
  };

  // Connected components of the graph (counted for the result).
  {
    std::vector<uint8_t> seen(static_cast<size_t>(m), 0);
    std::vector<int32_t> stack;
    for (int32_t s = 0; s < int32_t(m); ++s) {
      if (seen[size_t(s)]) continue;
      ++res.components;
      seen[size_t(s)] = 1;
      stack.assign(1, s);
      while (!stack.empty()) {
        const int32_t u = stack.back();
        stack.pop_back();
        for (int32_t v : adj[size_t(u)])
          if (!seen[size_t(v)]) {
            seen[size_t(v)] = 1;
            stack.push_back(v);
          }
      }
    }
  }

  // Closed surfaces: every point the flood fill decides takes its side (inside_outside.hpp),
  // and the tree grows from all of them at once, so an undecided point takes the sign of its
  // most confident path to a decided one.
  std::unique_ptr<detail::InsideOutside> sides;
  if (options.inside_outside && m >= 4) {
    detail::InsideOutsideOptions io;
    io.typical_spacing = median_spacing;
    sides = std::make_unique<detail::InsideOutside>(pts, guide, spacing, io, options.run.threads);
    res.voxel = sides->voxel();
    std::vector<int8_t> vote = sides->votes();
    for (Eigen::Index i = 0; i < m; ++i)
      if (vote[size_t(i)] < 0) guide.row(i) *= -1.0;
    // A vote its decided neighbours disagree with (on the whole, weighted by the pairs'
    // consistency) is dropped: the tree then reaches that point from them.
    {
      std::vector<int8_t> keep = vote;
      for (Eigen::Index i = 0; i < m; ++i) {
        if (vote[size_t(i)] == 0) continue;
        double agree = 0, total = 0;
        for (int32_t j : adj[size_t(i)]) {
          if (vote[size_t(j)] == 0) continue;
          const double c = consistency(int32_t(i), j);
          agree += c;
          total += std::abs(c);
        }
        if (total > 0 && agree < -kCleanup * total) keep[size_t(i)] = 0;
      }
      vote.swap(keep);
    }
    // All decided points are marked first, so only edges into undecided points enter the heap.
    for (Eigen::Index i = 0; i < m; ++i)
      if (vote[size_t(i)] != 0) {
        visited[size_t(i)] = 1;
        ++res.inside_outside_votes;
      }
    for (Eigen::Index i = 0; i < m; ++i)
      if (vote[size_t(i)] != 0) visit(int32_t(i));
    drain(nullptr);
  }

  std::vector<int32_t> members;
  for (int32_t seed : order) {
    if (visited[size_t(seed)]) continue;
    if (guide(seed, 2) < 0) guide.row(seed) *= -1.0;
    members.assign(1, seed);
    visit(seed);
    drain(&members);
    // Global sign of the component: outward on the whole, sum_i (p_i - centroid) . n_i >= 0
    // (3 x the enclosed volume on a closed surface, divergence theorem). One seed normal decides
    // badly where the top is a rim or a thin edge.
    if (options.outward_vote && members.size() > 1) {
      Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
      for (int32_t u : members) c += pts.row(u);
      c /= double(members.size());
      double flux = 0;
      for (int32_t u : members) flux += (pts.row(u) - c).dot(guide.row(u));
      if (flux < 0)
        for (int32_t u : members) guide.row(u) *= -1.0;
    }
  }
  progress.throw_if_cancelled();

  // Signs to the caller's normals (only the sign changes, the length stays the caller's); a
  // normal perpendicular to its oriented guide has no sign to take.
  std::vector<uint8_t> oriented(static_cast<size_t>(m), 0);
  for (Eigen::Index li = 0; li < m; ++li) {
    const int64_t row = used[size_t(li)];
    double d = normals.row(row).dot(guide.row(li));
    // A normal far from its guide (a sharp normal at an edge, where the guide is the bisector)
    // takes its own side from the flood fill where that decides.
    if (sides && sides->voxel() > 0 &&
        std::abs(d) < kOwnVoteCos * normals.row(row).norm()) {
      const int8_t v = sides->vote(pts.row(li), normals.row(row).normalized());
      if (v != 0) d = double(v);
    }
    if (!(d != 0)) {
      ++res.unoriented;
      continue;
    }
    oriented[size_t(li)] = 1;
    if (d < 0) {
      normals.row(row) *= -1.0;
      ++res.flipped;
    }
  }
  return oriented;
}

/// MST orientation with exact duplicates seen once: k copies of a position would form their
/// own k-NN component (each copy's neighbours are the other copies) and be oriented apart from
/// the surface. Only the first copy takes part; every other copy then takes its sign (the
/// estimator gives all copies the same normal, so they end up identical).
void orient_mst_deduplicated(const Points& points, Normals& normals,
                             const std::vector<int64_t>& used, const OrientOptions& options,
                             OrientResult& res) {
  std::vector<int64_t> firsts = used;
  const std::vector<int64_t> first_of = detail::dedupe_exact(points, firsts);
  std::sort(firsts.begin(), firsts.end());  // input order, as without duplicates
  const std::vector<uint8_t> oriented = orient_mst(points, normals, firsts, options, res);
  if (firsts.size() == used.size()) return;
  std::vector<int64_t> slot(size_t(points.rows()), -1);  // row -> index in firsts
  for (size_t i = 0; i < firsts.size(); ++i) slot[size_t(firsts[i])] = int64_t(i);
  for (const int64_t row : used) {
    const int64_t first = first_of[size_t(row)];
    if (first == row) continue;
    const double d = normals.row(row).dot(normals.row(first));
    if (!oriented[size_t(slot[size_t(first)])] || !(d != 0)) {
      ++res.unoriented;
      continue;
    }
    if (d < 0) {
      normals.row(row) *= -1.0;
      ++res.flipped;
    }
  }
}

}  // namespace

OrientResult orient_normals(const Points& points, Normals& normals, const OrientOptions& options,
                            const Normals& reference) {
  if (normals.rows() != points.rows())
    throw InvalidOptions("orient: " + std::to_string(normals.rows()) + " normals for " +
                         std::to_string(points.rows()) + " points");
  if (options.mode == OrientMode::Mst && options.k < 2)
    throw InvalidOptions("orient: mst needs k >= 2, got " + std::to_string(options.k));
  if (options.mode == OrientMode::Mst && options.smooth_guide && options.guide_k < 3)
    throw InvalidOptions("orient: the guide needs guide_k >= 3, got " +
                         std::to_string(options.guide_k));
  if (options.mode == OrientMode::Viewpoint && !options.viewpoint.allFinite())
    throw InvalidOptions("orient: the viewpoint must have finite coordinates");
  if (options.mode == OrientMode::Keep && reference.rows() != points.rows())
    throw InvalidOptions("orient keep: needs one reference normal per point (the input has " +
                         std::to_string(reference.rows()) + " for " +
                         std::to_string(points.rows()) + " points)");
  if (options.run.threads < 0) throw InvalidOptions("orient: threads must be >= 0");
  detail::start_threads(options.run.threads);  // before the big allocations

  OrientResult res;
  std::vector<int64_t> used;
  used.reserve(size_t(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (points.row(i).allFinite() && valid_normal(normals.row(i)))
      used.push_back(i);
    else
      ++res.invalid;
  }

  switch (options.mode) {
    case OrientMode::None:
      break;
    case OrientMode::Keep:
      for (int64_t i : used) {
        const double d = normals.row(i).dot(reference.row(i));
        if (!std::isfinite(d) || d == 0) ++res.unoriented;
      }
      res.flipped = orient_like(normals, reference);
      break;
    case OrientMode::Viewpoint:
      for (int64_t i : used) {
        const double d = (options.viewpoint.transpose() - points.row(i)).dot(normals.row(i));
        if (d < 0) {
          normals.row(i) *= -1.0;
          ++res.flipped;
        } else if (!(d > 0)) {
          ++res.unoriented;
        }
      }
      break;
    case OrientMode::Mst:
      orient_mst_deduplicated(points, normals, used, options, res);
      break;
  }
  return res;
}

}  // namespace nhnet
