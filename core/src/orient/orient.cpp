// Normal orientation (keep / viewpoint / MST / up, Hoppe et al. 1992, with a reflection criterion),
// see orient.hpp. The arrays never change order.
#include "nhnet/orient/orient.hpp"

#include "neighbors/dedupe.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/geometry/pca.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "orient/inside_outside.hpp"
#include "orient/sensors.hpp"
#include "util/parallel.hpp"
#include "util/stats.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

namespace nhnet {

OrientMode orient_mode_from_string(const std::string& name) {
  if (name == "none") return OrientMode::None;
  if (name == "keep") return OrientMode::Keep;
  if (name == "viewpoint") return OrientMode::Viewpoint;
  if (name == "mst") return OrientMode::Mst;
  if (name == "sensors") return OrientMode::Sensors;
  if (name == "up") return OrientMode::Up;
  if (name == "auto") return OrientMode::Auto;
  throw InvalidOptions("unknown orientation '" + name +
                       "' (expected auto, keep, viewpoint, sensors, up, mst or none)");
}

const char* to_string(OrientMode mode) {
  switch (mode) {
    case OrientMode::None: return "none";
    case OrientMode::Keep: return "keep";
    case OrientMode::Viewpoint: return "viewpoint";
    case OrientMode::Mst: return "mst";
    case OrientMode::Sensors: return "sensors";
    case OrientMode::Up: return "up";
    case OrientMode::Auto: return "auto";
  }
  return "?";
}

int64_t orient_like(Normals& normals, const Normals& reference) {
  if (normals.rows() != reference.rows())
    throw InvalidOptions("orient_like: normals and reference differ in size");
  int64_t flipped = 0;
  for (Eigen::Index i = 0; i < normals.rows(); ++i) {
    const double d = normals.row(i).dot(reference.row(i));
    if (std::isfinite(d) && d < 0) {
      normals.row(i) *= -1.0;
      ++flipped;
    }
  }
  return flipped;
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

/// Adjacency lists over the rows of the points being oriented, in one array (compressed rows:
/// a million small vectors cost more to allocate and free than the MST takes to walk them).
class Adjacency {
 public:
  /// The neighbours of one point, sorted.
  struct Row {
    const int32_t* b;
    const int32_t* e;
    const int32_t* begin() const { return b; }
    const int32_t* end() const { return e; }
  };
  Row operator[](size_t i) const {
    return {next_.data() + start_[i], next_.data() + start_[i + 1]};
  }
  size_t size() const { return start_.empty() ? 0 : start_.size() - 1; }

  /// The symmetric graph of a neighbour table (an edge when either point lists the other among
  /// its first `k` columns, self excluded): each row sorted, without repeats.
  void link(const IndexMatrix& knn, int k, int threads);

 private:
  std::vector<int64_t> start_{0};  // row i is next_[start_[i], start_[i + 1])
  std::vector<int32_t> next_;
};

void Adjacency::link(const IndexMatrix& knn, int k, int threads) {
  const Eigen::Index m = knn.rows();
  // Reverse edges first: row j lists every i that lists j, in ascending i (one serial pass).
  std::vector<int64_t> rstart(size_t(m) + 1, 0);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index c = 1; c < k; ++c)
      if (knn(i, c) != int32_t(i)) ++rstart[size_t(knn(i, c)) + 1];
  for (size_t i = 0; i < size_t(m); ++i) rstart[i + 1] += rstart[i];
  std::vector<int32_t> reverse(size_t(rstart.back()));
  std::vector<int64_t> fill(rstart.begin(), rstart.end() - 1);
  for (Eigen::Index i = 0; i < m; ++i)
    for (Eigen::Index c = 1; c < k; ++c)
      if (knn(i, c) != int32_t(i)) reverse[size_t(fill[size_t(knn(i, c))]++)] = int32_t(i);
  // Row i holds at most its own k - 1 and its reverse edges: each row's own neighbours sorted
  // and merged with its (sorted) reverse ones without repeats, in parallel; then the gaps close.
  std::vector<int64_t> start(size_t(m) + 1, 0);
  for (size_t i = 0; i < size_t(m); ++i)
    start[i + 1] = start[i] + (k - 1) + (rstart[i + 1] - rstart[i]);
  std::vector<int32_t> next(size_t(start.back()));
  std::vector<int64_t> kept(static_cast<size_t>(m));
  detail::parallel_for(m, threads, nullptr, [&](int64_t i) {
    thread_local std::vector<int32_t> own;
    own.clear();
    for (Eigen::Index c = 1; c < k; ++c)
      if (knn(i, c) != int32_t(i)) own.push_back(knn(i, c));
    std::sort(own.begin(), own.end());
    const int32_t* rb = reverse.data() + rstart[size_t(i)];
    const int32_t* re = reverse.data() + rstart[size_t(i) + 1];
    int32_t* out = next.data() + start[size_t(i)];
    kept[size_t(i)] = std::set_union(own.begin(), own.end(), rb, re, out) - out;
  });
  // In place, front to back: a row's new start is never after its old one (a fresh array
  // would cost as much in first-touch page faults as the copy itself).
  start_.assign(size_t(m) + 1, 0);
  for (size_t i = 0; i < size_t(m); ++i) {
    start_[i + 1] = start_[i] + kept[i];
    std::copy_n(next.data() + start[i], kept[i], next.data() + start_[i]);
  }
  next.resize(size_t(start_.back()));
  next_.swap(next);
}

/// The symmetric k-NN graph of the points being oriented, and the scales measured on it.
struct Graph {
  Adjacency adj;              ///< each point's neighbours, sorted, without itself
  double noise = 0;           ///< typical offset of a neighbour from a point's guide plane
  double spacing = 0;         ///< mean distance to the nearest other point (the flood fill's unit)
  double median_spacing = 0;  ///< its median (blind to a few far outliers)
  std::vector<double> nearest;  ///< per point, that distance (+inf without edges)
};

/// Copies the rows `used` of points and normals into pts and guide (unit length: the first guide).
void gather_rows(const Points& points, const Normals& normals, const std::vector<int64_t>& used,
                 Points& pts, Normals& guide) {
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    pts.row(i) = points.row(used[size_t(i)]);
    guide.row(i) = normals.row(used[size_t(i)]).normalized();
  }
}

/// OrientOptions::guides: the given guides of the rows `used` replace the first guide.
void take_guides(const OrientOptions& options, const std::vector<int64_t>& used, Normals& guide) {
  if (!options.guides) return;
  for (Eigen::Index i = 0; i < guide.rows(); ++i)
    guide.row(i) = options.guides->row(Eigen::Index(used[size_t(i)]));
}

/// For each of the caller's n rows, the index of its point in pts (pts row i is caller row
/// rows[i], rows distinct and below n), -1 for a row not among them.
std::vector<int32_t> point_of_row(const std::vector<int64_t>& rows, Eigen::Index n) {
  std::vector<int32_t> at(size_t(n), -1);
  for (size_t i = 0; i < rows.size(); ++i) at[size_t(rows[i])] = int32_t(i);
  return at;
}

/// The symmetric k-NN graph of the first `k` columns of `knn` (an edge when either point is
/// among the other's k nearest, self included) as adjacency lists, with the mean and median
/// distance to the nearest other point. The mean is summed in caller-row order (`at`:
/// point_of_row of build_graph's rows), so it has the same bits whatever order the points come
/// in, as a distributed driver's sum of mst_nearest().
void link_neighbours(const Points& pts, const IndexMatrix& knn, int k, int threads,
                     const std::vector<int32_t>& at, Graph& graph) {
  const Eigen::Index m = pts.rows();
  graph.adj.link(knn, k, threads);
  graph.nearest.assign(size_t(m), std::numeric_limits<double>::infinity());
  detail::parallel_for(m, threads, nullptr, [&](int64_t i) {
    double nearest = std::numeric_limits<double>::infinity();
    for (Eigen::Index c = 1; c < k; ++c) {
      const int32_t j = knn(i, c);
      if (j == int32_t(i)) continue;
      nearest = std::min(nearest, (pts.row(j) - pts.row(i)).norm());
    }
    graph.nearest[size_t(i)] = nearest;
  });
  int64_t counted = 0;
  std::vector<double> nearest_all;
  nearest_all.reserve(size_t(m));
  for (const int32_t i : at) {
    if (i < 0) continue;  // a caller row not among pts
    const double nearest = graph.nearest[size_t(i)];
    if (std::isfinite(nearest)) {
      graph.spacing += nearest;
      nearest_all.push_back(nearest);
      ++counted;
    }
  }
  if (counted > 0) graph.spacing /= double(counted);
  graph.median_spacing = detail::quantile(std::move(nearest_all), 0.5);
}

/// Smooth guide (OrientOptions::smooth_guide): PCA normals over the first guide_k columns of
/// the shared neighbour table, where they are finite.
void smooth_guide(const Points& pts, const IndexMatrix& knn, int guide_k, const RunContext& sub,
                  Normals& guide) {
  const Normals pca = pca_normals(pts, knn, PcaOptions{guide_k}, sub).normals;
  for (Eigen::Index i = 0; i < pts.rows(); ++i)
    if (pca.row(i).allFinite()) guide.row(i) = pca.row(i);
}

/// Noise: the median over the points of the median offset |(p_j - p_i) . g_i| of their graph
/// neighbours (~0.95 sigma on a noisy plane); a median, so a wall's other side (a minority of
/// the k nearest) does not count. 0 without edges.
double guide_noise(const Points& pts, const Normals& guide, const Adjacency& adj, int threads) {
  const Eigen::Index m = pts.rows();
  std::vector<double> typical(size_t(m), -1.0);  // -1: no edges
  detail::parallel_for(m, threads, nullptr, [&](int64_t i) {
    thread_local std::vector<double> off;
    off.clear();
    for (int32_t j : adj[size_t(i)])
      off.push_back(std::abs(guide.row(i).dot(pts.row(j) - pts.row(i))));
    if (off.empty()) return;
    std::nth_element(off.begin(), off.begin() + off.size() / 2, off.end());
    typical[size_t(i)] = off[off.size() / 2];
  });
  typical.erase(std::remove(typical.begin(), typical.end(), -1.0), typical.end());
  if (typical.empty()) return 0;
  std::nth_element(typical.begin(), typical.begin() + typical.size() / 2, typical.end());
  return typical[typical.size() / 2];
}

/// OrientOptions::neighbours when it serves: `every_row` (pts are all the caller's points) and
/// at least `depth` columns; else null.
const IndexMatrix* given_table(const OrientOptions& options, bool every_row, int depth) {
  const IndexMatrix* t = options.neighbours.get();
  return t && every_row && t->cols() >= depth ? t : nullptr;
}

/// The first `depth` columns of a table of the caller's rows for pts taken in the order `rows`
/// (pts row i is caller row rows[i], every caller row once; `at` its point_of_row): its rows
/// and entries renumbered.
IndexMatrix renumbered(const IndexMatrix& table, const std::vector<int64_t>& rows,
                       const std::vector<int32_t>& at, int depth, int threads) {
  IndexMatrix out(Eigen::Index(rows.size()), depth);
  detail::parallel_for(int64_t(rows.size()), threads, nullptr, [&](int64_t i) {
    for (int c = 0; c < depth; ++c) out(i, c) = at[size_t(table(rows[size_t(i)], c))];
  });
  return out;
}

/// Whether rows is 0, 1, 2, ...
bool in_order(const std::vector<int64_t>& rows) {
  for (size_t i = 0; i < rows.size(); ++i)
    if (rows[i] != int64_t(i)) return false;
  return true;
}

/// The graph over pts and its scales; smooths `guide` on the way (one neighbour search for
/// both: the graph takes the first k columns of the guide's guide_k-deep table), unless the
/// guides were given (OrientOptions::guides: the table keeps its depth, the same graph). The
/// table is OrientOptions::neighbours where given_table() takes it (`rows`: the caller's row of
/// each of pts, `n` the caller's point count).
Graph build_graph(const Points& pts, Normals& guide, const OrientOptions& options,
                  const std::vector<int64_t>& rows, Eigen::Index n) {
  const Eigen::Index m = pts.rows();
  Graph graph;
  if (m <= 1) {
    graph.adj.link(IndexMatrix(m, 1), 1, 1);
    return graph;
  }
  RunContext sub;
  sub.threads = options.run.threads;
  const bool smooth = options.smooth_guide && m >= 3;
  const int k = int(std::min<Eigen::Index>(options.k, m));
  const int guide_k = int(std::min<Eigen::Index>(options.guide_k, m));
  const int depth = smooth ? std::max(k, guide_k) : k;
  const std::vector<int32_t> at = point_of_row(rows, n);
  IndexMatrix searched;
  const IndexMatrix* given = given_table(options, m == n, depth);
  const bool as_given = given && in_order(rows);
  if (!given)
    Neighbors(pts).knn_all(depth, searched, nullptr, sub);
  else if (!as_given)
    searched = renumbered(*given, rows, at, depth, sub.threads);
  const IndexMatrix& knn = as_given ? *given : searched;
  link_neighbours(pts, knn, k, sub.threads, at, graph);
  if (smooth && !options.guides) smooth_guide(pts, knn, guide_k, sub, guide);
  graph.noise = guide_noise(pts, guide, graph.adj, sub.threads);
  return graph;
}

/// Connected components of the graph (counted for the result), by depth-first search.
int64_t count_components(const Adjacency& adj) {
  int64_t components = 0;
  std::vector<uint8_t> seen(adj.size(), 0);
  std::vector<int32_t> stack;
  for (int32_t s = 0; s < int32_t(adj.size()); ++s) {
    if (seen[size_t(s)]) continue;
    ++components;
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
  return components;
}

/// Prim's algorithm over the graph, on the guide normals: each edge costs 1 - |c_ij|, so the
/// sign travels along the most confident pairs. Trees grown one after the other share one heap
/// and one visited set.
class Prim {
 public:
  Prim(const Points& pts, Normals& guide, const Graph& graph, const OrientOptions& options,
       detail::Progress& progress)
      : pts_(pts),
        guide_(guide),
        graph_(graph),
        options_(options),
        progress_(progress),
        visited_(static_cast<size_t>(pts.rows()), 0),
        frontier_(static_cast<size_t>(pts.rows())) {}

  /// Consistency of the pair (i, j): c_ij > 0 when the signs agree. Hoppe: g_i . g_j.
  /// Reflection (OrientOptions::reflect): g_i mirrored at the bisecting plane of p_i p_j,
  /// dotted with g_j,
  ///   c_ij = g_i . g_j - 2 (g_i . u)(g_j . u),  u = (p_j - p_i) / |p_j - p_i|,
  /// which maps a normal exactly onto its neighbour's on a sphere, across a sharp edge (cube
  /// faces: |c| = 1 where g_i . g_j = 0) and across a thin wall (opposite sides: c = +1 for
  /// outward normals facing away from each other, where g_i . g_j = -1 would copy the sign).
  double consistency(int32_t i, int32_t j) const {
    const Eigen::RowVector3d gi = guide_.row(i), gj = guide_.row(j);
    double c = gi.dot(gj);
    if (options_.reflect) {
      const Eigen::RowVector3d d = pts_.row(j) - pts_.row(i);
      const double len2 = d.squaredNorm();
      const double a = gi.dot(d), b = gj.dot(d);
      const double floor = options_.reflect_noise * graph_.noise;
      if (len2 > 0 &&
          std::min(a * a, b * b) >= options_.reflect_min * options_.reflect_min * len2 &&
          std::min(std::abs(a), std::abs(b)) > floor)
        c -= 2.0 * a * b / len2;
    }
    return c;
  }

  bool visited(int32_t u) const { return visited_[size_t(u)] != 0; }
  /// Marks u as reached without queueing its edges (visit() follows).
  void mark(int32_t u) { visited_[size_t(u)] = 1; }

  /// Marks u as reached and offers each point not yet reached its edge from u (kept when it is
  /// that point's cheapest so far); reports progress.
  void visit(int32_t u) {
    visited_[size_t(u)] = 1;
    // The neighbours' rows are scattered (the frontier wanders): fetch them all before the
    // first is needed, so their cache misses overlap.
#if defined(__GNUC__) || defined(__clang__)
    for (int32_t v : graph_.adj[size_t(u)]) {
      __builtin_prefetch(guide_.row(v).data());
      __builtin_prefetch(pts_.row(v).data());
    }
#endif
    for (int32_t v : graph_.adj[size_t(u)])
      if (!visited_[size_t(v)]) frontier_.offer(v, 1.0 - std::abs(consistency(u, v)), u);
    if ((++done_ & 4095) == 0 && options_.run.progress &&
        !progress_.report(double(done_) / double(pts_.rows())))
      progress_.throw_if_cancelled();
  }

  /// Grows the trees until no point is offered: the point with the cheapest edge is reached
  /// next and turns its guide to agree with the point it is reached from (and joins `members`
  /// when given).
  void drain(std::vector<int32_t>* members) {
    while (!frontier_.empty()) {
      int32_t from = 0;
      const int32_t to = frontier_.pop(from);
      if (consistency(from, to) < 0) guide_.row(to) *= -1.0;
      if (members) members->push_back(to);
      visit(to);
    }
  }

 private:
  /// The points not yet reached that have an edge from a reached one, each with its cheapest
  /// edge, in an indexed 4-ary min-heap: one entry per point (an edge that is no longer the
  /// point's cheapest is dropped at once, not queued and skipped later), so the heap stays as
  /// small as the frontier. Pops in the order of a queue of all edges (Prim's lazy form) but
  /// for exact ties of cost.
  class Frontier {
   public:
    explicit Frontier(size_t n) : from_(n, -1), slot_(n, -1) {}
    bool empty() const { return heap_.empty(); }
    void offer(int32_t v, double cost, int32_t from) {
      int32_t at = slot_[size_t(v)];
      if (at >= 0 && !(cost < heap_[size_t(at)].cost)) return;
      from_[size_t(v)] = from;
      if (at < 0) {
        at = int32_t(heap_.size());
        heap_.push_back({cost, v});
      }
      up(at, {cost, v});
    }
    /// Removes the point with the cheapest edge; its source in `from`.
    int32_t pop(int32_t& from) {
      const int32_t v = heap_.front().v;
      from = from_[size_t(v)];
      slot_[size_t(v)] = -1;
      const Entry last = heap_.back();
      heap_.pop_back();
      if (!heap_.empty()) down(0, last);
      return v;
    }

   private:
    /// A point in the heap with its cheapest edge's cost (kept beside it: the sifts compare
    /// costs without a lookup per child).
    struct Entry {
      double cost;
      int32_t v;
    };
    void place(int32_t at, const Entry& e) {
      heap_[size_t(at)] = e;
      slot_[size_t(e.v)] = at;
    }
    /// Sifts e up from slot `at` (whose entry it replaces).
    void up(int32_t at, const Entry& e) {
      while (at > 0) {
        const int32_t parent = (at - 1) / 4;
        if (!(e.cost < heap_[size_t(parent)].cost)) break;
        place(at, heap_[size_t(parent)]);
        at = parent;
      }
      place(at, e);
    }
    /// Sifts e down from slot `at` (whose entry it replaces).
    void down(int32_t at, const Entry& e) {
      const int32_t n = int32_t(heap_.size());
      for (;;) {
        const int32_t first = 4 * at + 1;
        if (first >= n) break;
        int32_t best = first;
        for (int32_t c = first + 1; c < std::min(first + 4, n); ++c)
          if (heap_[size_t(c)].cost < heap_[size_t(best)].cost) best = c;
        if (!(heap_[size_t(best)].cost < e.cost)) break;
        place(at, heap_[size_t(best)]);
        at = best;
      }
      place(at, e);
    }

    std::vector<int32_t> from_;  // per point: its cheapest edge's reached end (while in the heap)
    std::vector<int32_t> slot_;  // per point: its place in heap_, -1 when not there
    std::vector<Entry> heap_;    // points, cheapest edge first
  };

  const Points& pts_;
  Normals& guide_;
  const Graph& graph_;
  const OrientOptions& options_;
  detail::Progress& progress_;
  std::vector<uint8_t> visited_;
  Frontier frontier_;
  int64_t done_ = 0;
};

/// A vote its decided neighbours disagree with (on the whole, weighted by the pairs'
/// consistency) is dropped: the tree then reaches that point from them.
void drop_disputed_votes(const Prim& prim, const Adjacency& adj, std::vector<int8_t>& vote) {
  std::vector<int8_t> keep = vote;
  for (Eigen::Index i = 0; i < Eigen::Index(vote.size()); ++i) {
    if (vote[size_t(i)] == 0) continue;
    double agree = 0, total = 0;
    for (int32_t j : adj[size_t(i)]) {
      if (vote[size_t(j)] == 0) continue;
      const double c = prim.consistency(int32_t(i), j);
      agree += c;
      total += std::abs(c);
    }
    if (total > 0 && agree < -kCleanup * total) keep[size_t(i)] = 0;
  }
  vote.swap(keep);
}

/// Grows the trees from every point with a vote (its guide already turned to it) at once, so
/// an undecided point takes the sign of its most confident path to a decided one. Returns how
/// many points had a vote.
int64_t grow_from_votes(Prim& prim, const std::vector<int8_t>& vote) {
  const Eigen::Index m = Eigen::Index(vote.size());
  int64_t decided = 0;
  // All decided points are marked first, so only edges into undecided points enter the heap.
  for (Eigen::Index i = 0; i < m; ++i)
    if (vote[size_t(i)] != 0) {
      prim.mark(int32_t(i));
      ++decided;
    }
  for (Eigen::Index i = 0; i < m; ++i)
    if (vote[size_t(i)] != 0) prim.visit(int32_t(i));
  prim.drain(nullptr);
  return decided;
}

/// Closed surfaces: every point the flood fill decides takes its side (inside_outside.hpp),
/// and the trees grow from all of them at once (grow_from_votes). Returns the flood fill (for
/// copy_signs).
std::unique_ptr<detail::InsideOutside> grow_from_sides(Prim& prim, const Points& pts,
                                                       Normals& guide, const Graph& graph,
                                                       const OrientOptions& options,
                                                       OrientResult& res) {
  detail::InsideOutsideOptions io;
  io.typical_spacing = graph.median_spacing;
  auto sides = options.sides ? std::make_unique<detail::InsideOutside>(pts, guide, *options.sides,
                                                                       options.run.threads)
                             : std::make_unique<detail::InsideOutside>(pts, guide, graph.spacing,
                                                                       io, options.run.threads);
  res.voxel = sides->voxel();
  std::vector<int8_t> vote = sides->votes();
  for (Eigen::Index i = 0; i < guide.rows(); ++i)
    if (vote[size_t(i)] < 0) guide.row(i) *= -1.0;
  drop_disputed_votes(prim, graph.adj, vote);
  res.inside_outside_votes += grow_from_votes(prim, vote);
  return sides;
}

/// Up mode: the guides with |g_z| >= min_z turned up are the seeds (detail::up_votes).
void grow_from_up(Prim& prim, Normals& guide, double min_z) {
  const std::vector<int8_t> vote = detail::up_votes(guide, min_z);
  for (Eigen::Index i = 0; i < guide.rows(); ++i)
    if (vote[size_t(i)] < 0) guide.row(i) *= -1.0;
  grow_from_votes(prim, vote);
}

/// Global sign of a tree: outward on the whole, sum_i (p_i - centroid) . n_i >= 0 (3 x the
/// enclosed volume on a closed surface, divergence theorem). One seed normal decides badly
/// where the top is a rim or a thin edge.
void turn_outward(const Points& pts, Normals& guide, const std::vector<int32_t>& members) {
  Eigen::RowVector3d c = Eigen::RowVector3d::Zero();
  for (int32_t u : members) c += pts.row(u);
  c /= double(members.size());
  double flux = 0;
  for (int32_t u : members) flux += (pts.row(u) - c).dot(guide.row(u));
  if (flux < 0)
    for (int32_t u : members) guide.row(u) *= -1.0;
}

/// One tree per component not yet reached, grown from its highest point (its guide turned to
/// +z: outward on a closed surface), then turned outward (OrientOptions::outward_vote).
void grow_from_tops(Prim& prim, const Points& pts, Normals& guide, const OrientOptions& options) {
  std::vector<int32_t> order;  // the points not reached yet (the others would be skipped)
  for (int32_t i = 0; i < int32_t(pts.rows()); ++i)
    if (!prim.visited(i)) order.push_back(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return pts(a, 2) > pts(b, 2); });
  std::vector<int32_t> members;
  for (int32_t seed : order) {
    if (prim.visited(seed)) continue;
    if (guide(seed, 2) < 0) guide.row(seed) *= -1.0;
    members.assign(1, seed);
    prim.visit(seed);
    prim.drain(&members);
    if (options.outward_vote && members.size() > 1) turn_outward(pts, guide, members);
  }
}

/// Signs to the caller's normals (only the sign changes, the length stays the caller's); a
/// normal perpendicular to its oriented guide has no sign to take. Returns for every entry of
/// `used` whether it was oriented.
std::vector<uint8_t> copy_signs(const Points& pts, const Normals& guide,
                                const detail::InsideOutside* sides,
                                const std::vector<int64_t>& used, Normals& normals,
                                OrientResult& res, int threads) {
  const Eigen::Index m = pts.rows();
  std::vector<int8_t> sign(static_cast<size_t>(m), 0);  // +1 keep, -1 flip, 0 no sign
  detail::parallel_for(m, threads, nullptr, [&](int64_t li) {
    const auto n = normals.row(used[size_t(li)]);
    double d = n.dot(guide.row(li));
    // A normal far from its guide (a sharp normal at an edge, where the guide is the bisector)
    // takes its own side from the flood fill where that decides.
    if (sides && sides->voxel() > 0 && std::abs(d) < kOwnVoteCos * n.norm()) {
      const int8_t v = sides->vote(pts.row(li), n.normalized());
      if (v != 0) d = double(v);
    }
    sign[size_t(li)] = int8_t(d > 0 ? 1 : d < 0 ? -1 : 0);  // NaN: no sign
  });
  std::vector<uint8_t> oriented(static_cast<size_t>(m), 0);
  for (Eigen::Index li = 0; li < m; ++li) {
    if (sign[size_t(li)] == 0) {
      ++res.unoriented;
      continue;
    }
    oriented[size_t(li)] = 1;
    if (sign[size_t(li)] < 0) {
      normals.row(used[size_t(li)]) *= -1.0;
      ++res.flipped;
    }
  }
  return oriented;
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
  gather_rows(points, normals, used, pts, guide);
  take_guides(options, used, guide);

  if (options.run.progress) progress.stage("orient: neighbours", 0, 0.3);
  const Graph graph = build_graph(pts, guide, options, used, points.rows());
  progress.throw_if_cancelled();

  if (options.run.progress) progress.stage("orient: mst", 0.3, 1.0);
  Prim prim(pts, guide, graph, options, progress);
  res.components += count_components(graph.adj);
  std::unique_ptr<detail::InsideOutside> sides;
  if (options.mode == OrientMode::Up)
    grow_from_up(prim, guide, options.up_min_z);
  else if (options.inside_outside && m >= 4)
    sides = grow_from_sides(prim, pts, guide, graph, options, res);
  grow_from_tops(prim, pts, guide, options);
  progress.throw_if_cancelled();

  return copy_signs(pts, guide, sides.get(), used, normals, res, options.run.threads);
}

/// MST orientation with exact duplicates seen once: k copies of a position would form their
/// own k-NN component (each copy's neighbours are the other copies) and be oriented apart from
/// the surface. Only the first copy takes part; every other copy then takes its sign (the
/// estimator gives all copies the same normal, so they end up identical).
void orient_mst_deduplicated(const Points& points, Normals& normals,
                             const std::vector<int64_t>& used, const OrientOptions& options,
                             OrientResult& res) {
  std::vector<int64_t> firsts = used;
  // In the dedupe's Morton order: the graph and the tree read nearby memory (Prim's ties and the
  // equal heights of grow_from_tops break by this order).
  const std::vector<int64_t> first_of = detail::dedupe_exact(points, firsts);
  const std::vector<uint8_t> oriented = orient_mst(points, normals, firsts, options, res);
  if (firsts.size() == used.size()) return;
  const std::vector<int32_t> slot = point_of_row(firsts, points.rows());  // row -> in firsts
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

/// Throws InvalidOptions unless `table` (when given) has one row per point, itself first, and
/// only row numbers of the points.
void check_table(const Points& points, const IndexMatrix* table) {
  if (!table) return;
  const Eigen::Index n = points.rows();
  bool ok = table->rows() == n && table->cols() >= 1;
  for (Eigen::Index i = 0; ok && i < n; ++i) {
    ok = (*table)(i, 0) == int32_t(i);
    for (Eigen::Index c = 1; ok && c < table->cols(); ++c)
      ok = (*table)(i, c) >= 0 && (*table)(i, c) < n;
  }
  if (!ok)
    throw InvalidOptions("orient: the neighbour table (" + std::to_string(table->rows()) + " x " +
                         std::to_string(table->cols()) + ") is not one of these " +
                         std::to_string(n) +
                         " points (rows of point numbers, each row's own first); pass "
                         "EstimateResult::neighbours of the same points");
}

/// Throws InvalidOptions for mismatched sizes or options the chosen mode cannot use.
void check_options(const Points& points, const Normals& normals, const OrientOptions& options,
                   const Normals& reference) {
  if (normals.rows() != points.rows())
    throw InvalidOptions("orient: " + std::to_string(normals.rows()) + " normals for " +
                         std::to_string(points.rows()) + " points");
  const bool mst = options.mode == OrientMode::Mst || options.mode == OrientMode::Up;
  if (options.mode == OrientMode::Auto)
    throw InvalidOptions(
        "orient: mode auto must first be resolved for the cloud "
        "(resolve_orientation, nhnet/orient/auto.hpp)");
  if (mst && options.k < 2)
    throw InvalidOptions("orient: mst needs k >= 2, got " + std::to_string(options.k));
  if (mst && options.smooth_guide && options.guide_k < 3)
    throw InvalidOptions("orient: the guide needs guide_k >= 3, got " +
                         std::to_string(options.guide_k));
  if (options.mode == OrientMode::Up && !(options.up_min_z > 0 && options.up_min_z < 1))
    throw InvalidOptions("orient up: up_min_z must be in (0, 1)");
  if (options.mode == OrientMode::Sensors) detail::check_sensors(points, options);
  if (options.mode == OrientMode::Viewpoint && !options.viewpoint.allFinite())
    throw InvalidOptions("orient: the viewpoint must have finite coordinates");
  if (options.mode == OrientMode::Keep && reference.rows() != points.rows())
    throw InvalidOptions("orient keep: needs one reference normal per point (the input has " +
                         std::to_string(reference.rows()) + " for " +
                         std::to_string(points.rows()) + " points)");
  if (options.run.threads < 0) throw InvalidOptions("orient: threads must be >= 0");
  if (options.guides && options.guides->rows() != points.rows())
    throw InvalidOptions("orient: " + std::to_string(options.guides->rows()) +
                         " guide normals for " + std::to_string(points.rows()) + " points");
  check_table(points, options.neighbours.get());
}

/// The rows with a finite point and a valid normal; the others are counted as invalid.
std::vector<int64_t> valid_rows(const Points& points, const Normals& normals, OrientResult& res) {
  std::vector<int64_t> used;
  used.reserve(size_t(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (points.row(i).allFinite() && valid_normal(normals.row(i)))
      used.push_back(i);
    else
      ++res.invalid;
  }
  return used;
}

/// Keep: the signs of the reference normals (orient_like); a missing or perpendicular
/// reference leaves its row unoriented.
void orient_keep(Normals& normals, const Normals& reference, const std::vector<int64_t>& used,
                 OrientResult& res) {
  for (int64_t i : used) {
    const double d = normals.row(i).dot(reference.row(i));
    if (!std::isfinite(d) || d == 0) ++res.unoriented;
  }
  res.flipped = orient_like(normals, reference);
}

}  // namespace

int shared_neighbours(const OrientOptions& options) {
  if (options.mode != OrientMode::Mst && options.mode != OrientMode::Up) return 0;
  return options.smooth_guide ? std::max(options.k, options.guide_k) : options.k;
}

OrientResult orient_normals(const Points& points, Normals& normals, const OrientOptions& options,
                            const Normals& reference) {
  check_options(points, normals, options, reference);
  detail::start_threads(options.run.threads);  // before the big allocations

  OrientResult res;
  const std::vector<int64_t> used = valid_rows(points, normals, res);
  switch (options.mode) {
    case OrientMode::None: break;
    case OrientMode::Keep: orient_keep(normals, reference, used, res); break;
    case OrientMode::Viewpoint:
      detail::orient_towards(points, normals, {options.viewpoint}, {}, used, res);
      break;
    case OrientMode::Mst: orient_mst_deduplicated(points, normals, used, options, res); break;
    case OrientMode::Sensors:
      detail::orient_towards(points, normals, options.sensors, options.sensor_index, used, res);
      break;
    case OrientMode::Up: {
      const Normals before = normals;
      OrientResult mst;
      orient_mst_deduplicated(points, normals, used, options, mst);
      detail::finish_up(before, normals, used, options.up_min_z, mst, res);
      break;
    }
    case OrientMode::Auto: break;  // refused by check_options
  }
  return res;
}

namespace {

/// A tile's distinct valid rows (ascending), their points and guides, and the MST's graph.
struct TileGraph {
  std::vector<int64_t> rows;
  Points pts;
  Normals guide;
  Graph graph;
};

TileGraph tile_graph(const Points& points, const Normals& normals, int64_t own,
                     const OrientOptions& options) {
  if (normals.rows() != points.rows() || own < 0 || own > points.rows())
    throw InvalidOptions("orient tile: " + std::to_string(normals.rows()) + " normals for " +
                         std::to_string(points.rows()) + " points, " + std::to_string(own) +
                         " of them own");
  OrientResult ignored;
  TileGraph t;
  t.rows = valid_rows(points, normals, ignored);
  detail::dedupe_exact(points, t.rows);
  std::sort(t.rows.begin(), t.rows.end());  // input order: the outputs are in ascending rows
  t.pts.resize(Eigen::Index(t.rows.size()), 3);
  t.guide.resize(Eigen::Index(t.rows.size()), 3);
  gather_rows(points, normals, t.rows, t.pts, t.guide);
  take_guides(options, t.rows, t.guide);
  t.graph = build_graph(t.pts, t.guide, options, t.rows, points.rows());
  return t;
}

}  // namespace

std::vector<double> mst_nearest(const Points& points, const Normals& normals, int64_t own,
                                const OrientOptions& options) {
  OrientOptions plain = options;
  plain.smooth_guide = false;  // the graph's first k columns are the same without the guide
  const TileGraph t = tile_graph(points, normals, own, plain);
  std::vector<double> out;
  for (size_t i = 0; i < t.rows.size(); ++i)
    if (t.rows[i] < own && i < t.graph.nearest.size() && std::isfinite(t.graph.nearest[i]))
      out.push_back(t.graph.nearest[i]);
  return out;
}

MstGuides mst_guides(const Points& points, const Normals& normals, int64_t own,
                     const OrientOptions& options) {
  const TileGraph t = tile_graph(points, normals, own, options);
  std::vector<Eigen::Index> mine;
  for (size_t i = 0; i < t.rows.size(); ++i)
    if (t.rows[i] < own) mine.push_back(Eigen::Index(i));
  MstGuides out;
  out.points.resize(Eigen::Index(mine.size()), 3);
  out.guides.resize(Eigen::Index(mine.size()), 3);
  for (size_t i = 0; i < mine.size(); ++i) {
    out.points.row(Eigen::Index(i)) = t.pts.row(mine[i]);
    out.guides.row(Eigen::Index(i)) = t.guide.row(mine[i]);
    const double d = mine[i] < Eigen::Index(t.graph.nearest.size())
                         ? t.graph.nearest[size_t(mine[i])]
                         : std::numeric_limits<double>::infinity();
    if (std::isfinite(d)) out.nearest.push_back(d);
  }
  out.row_guides.setConstant(points.rows(), 3, std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < t.rows.size(); ++i)
    out.row_guides.row(Eigen::Index(t.rows[i])) = t.guide.row(Eigen::Index(i));
  return out;
}

int64_t sides_leaked(const Points& points, const Normals& guides, const SidesGrid& grid,
                     int threads, int64_t limit) {
  if (guides.rows() != points.rows())
    throw InvalidOptions("sides_leaked: " + std::to_string(guides.rows()) + " guides for " +
                         std::to_string(points.rows()) + " points");
  return detail::InsideOutside::count_leaked(points, guides, grid, threads, limit);
}

}  // namespace nhnet
