// Normal orientation (keep / viewpoint / MST via CGAL's mst_orient_normals, Hoppe et al. 1992),
// see orient.hpp. CGAL packs the oriented points of the range it is given to the front, so it
// works on a range of indices into per-component copies; our arrays never change order.
#include "nhnet/orient.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/estimate.hpp"
#include "nhnet/neighbors.hpp"
#include "nhnet/pca.hpp"
#include "dedupe.hpp"
#include "parallel.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/mst_orient_normals.h>
#include <CGAL/property_map.h>

#include <algorithm>
#include <cmath>
#include <numeric>
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

using Kernel = CGAL::Simple_cartesian<double>;

bool valid_normal(const Eigen::RowVector3d& n) {
  const double len = n.norm();
  return std::isfinite(len) && len > 1e-12;
}

/// Union-find with path halving.
int32_t find_root(std::vector<int32_t>& parent, int32_t x) {
  while (parent[size_t(x)] != x) {
    parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
    x = parent[size_t(x)];
  }
  return x;
}

/// MST orientation of the rows `used` of points/normals, one CGAL call per k-NN component, on
/// the guide normals (see OrientOptions::smooth_guide); the signs then go to `normals`.
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

  // Components of the symmetric k-NN graph (an edge when either point is among the other's k
  // nearest, self included).
  const int k = int(std::min<Eigen::Index>(options.k, m));
  if (options.run.progress) progress.stage("orient: neighbours", 0, 0.2);
  std::vector<int32_t> parent(static_cast<size_t>(m));
  std::iota(parent.begin(), parent.end(), 0);
  IndexMatrix knn;
  if (m > 1) {
    const Neighbors tree(pts);
    RunContext sub;
    sub.threads = options.run.threads;
    tree.knn_all(k, knn, nullptr, sub);
    for (Eigen::Index i = 0; i < m; ++i)
      for (Eigen::Index c = 1; c < knn.cols(); ++c) {
        const int32_t a = find_root(parent, int32_t(i)), b = find_root(parent, knn(i, c));
        if (a != b) parent[size_t(std::max(a, b))] = std::min(a, b);
      }
    if (options.smooth_guide && m >= 3) {
      IndexMatrix gknn;
      tree.knn_all(options.guide_k, gknn, nullptr, sub);
      const Normals pca = pca_normals(pts, gknn, PcaOptions{int(gknn.cols())}, sub).normals;
      for (Eigen::Index i = 0; i < m; ++i)
        if (pca.row(i).allFinite()) guide.row(i) = pca.row(i);
    }
  }
  progress.throw_if_cancelled();
  std::vector<std::vector<int32_t>> comps;
  {
    std::vector<int32_t> comp_of(static_cast<size_t>(m), -1);
    for (Eigen::Index i = 0; i < m; ++i) {
      const int32_t r = find_root(parent, int32_t(i));
      if (comp_of[size_t(r)] < 0) {
        comp_of[size_t(r)] = int32_t(comps.size());
        comps.emplace_back();
      }
      comps[size_t(comp_of[size_t(r)])].push_back(int32_t(i));
    }
  }
  res.components = int64_t(comps.size());

  // One CGAL call per component, on copies indexed 0..size-1; CGAL reorders only `range`.
  std::vector<uint8_t> oriented(static_cast<size_t>(m), 0);
  int64_t done = 0;
  if (options.run.progress) progress.stage("orient: mst", 0.2, 1.0);
  for (const auto& comp : comps) {
    const size_t cs = comp.size();
    std::vector<Kernel::Point_3> cp;
    std::vector<Kernel::Vector_3> cn;
    cp.reserve(cs);
    cn.reserve(cs);
    for (int32_t li : comp) {
      cp.emplace_back(pts(li, 0), pts(li, 1), pts(li, 2));
      cn.emplace_back(guide(li, 0), guide(li, 1), guide(li, 2));
    }
    if (cs == 1) {
      // A lone point (only when the cloud has one valid point): the seed rule, +z.
      if (cn[0].z() < 0) cn[0] = -cn[0];
      oriented[size_t(comp[0])] = 1;
    } else {
      // CGAL seeds its tree at the highest point and orients what the tree reaches in its
      // mutual k-NN graph. A far outlier as the seed reaches (almost) nothing: when the seed's
      // tree stays smaller than k, the unreached points get a call of their own (their own
      // seed), instead of all taking their signs from the outlier in the completion below.
      std::vector<std::size_t> pending(cs);
      std::iota(pending.begin(), pending.end(), std::size_t(0));
      while (pending.size() >= 2) {
        std::vector<Kernel::Point_3> sp;
        std::vector<Kernel::Vector_3> sn;
        sp.reserve(pending.size());
        sn.reserve(pending.size());
        for (std::size_t t : pending) {
          sp.push_back(cp[t]);
          sn.push_back(cn[t]);
        }
        std::vector<std::size_t> range(pending.size());
        std::iota(range.begin(), range.end(), std::size_t(0));
        const auto first_unoriented = CGAL::mst_orient_normals(
            range, unsigned(std::max(2, std::min<int>(k, int(pending.size())))),
            CGAL::parameters::point_map(CGAL::make_property_map(sp))
                .normal_map(CGAL::make_property_map(sn))
                .geom_traits(Kernel()));
        for (auto it = range.begin(); it != first_unoriented; ++it) {
          oriented[size_t(comp[pending[*it]])] = 1;
          cn[pending[*it]] = sn[*it];
        }
        const auto reached = first_unoriented - range.begin();
        if (reached == 0 || reached >= k || first_unoriented == range.end()) break;
        std::vector<std::size_t> rest;
        for (auto it = first_unoriented; it != range.end(); ++it) rest.push_back(pending[*it]);
        pending = std::move(rest);
      }
    }
    for (size_t t = 0; t < cs; ++t) guide.row(comp[t]) << cn[t].x(), cn[t].y(), cn[t].z();
    done += int64_t(cs);
    if (options.run.progress && !progress.report(double(done) / double(m))) break;
  }
  progress.throw_if_cancelled();

  // Completion: points CGAL left unoriented take the sign of an oriented neighbour in the
  // symmetric k-NN graph, breadth first from every oriented point.
  if (std::count(oriented.begin(), oriented.end(), uint8_t(0)) > 0 && knn.rows() == m) {
    std::vector<std::vector<int32_t>> adj(static_cast<size_t>(m));
    for (Eigen::Index i = 0; i < m; ++i)
      for (Eigen::Index c = 1; c < knn.cols(); ++c) {
        adj[size_t(i)].push_back(knn(i, c));
        adj[size_t(knn(i, c))].push_back(int32_t(i));
      }
    std::vector<int32_t> queue;
    for (Eigen::Index i = 0; i < m; ++i)
      if (oriented[size_t(i)]) queue.push_back(int32_t(i));
    for (size_t q = 0; q < queue.size(); ++q) {
      const int32_t u = queue[q];
      for (int32_t v : adj[size_t(u)]) {
        if (oriented[size_t(v)]) continue;
        oriented[size_t(v)] = 1;
        if (guide.row(v).dot(guide.row(u)) < 0) guide.row(v) *= -1.0;
        ++res.completed;
        queue.push_back(v);
      }
    }
  }

  // Signs to the caller's normals (only the sign changes, the length stays the caller's).
  for (const auto& comp : comps) {
    int64_t left = 0;
    for (int32_t li : comp) {
      const int64_t row = used[size_t(li)];
      const double d = normals.row(row).dot(guide.row(li));
      if (!oriented[size_t(li)] || !(d != 0)) {
        ++left;
        continue;
      }
      if (d < 0) {
        normals.row(row) *= -1.0;
        ++res.flipped;
      }
    }
    if (left > 0) {
      ++res.unoriented_components;
      res.unoriented += left;
    }
  }
  for (Eigen::Index i = 0; i < m; ++i)
    if (oriented[size_t(i)] && !(normals.row(used[size_t(i)]).dot(guide.row(i)) != 0))
      oriented[size_t(i)] = 0;
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
