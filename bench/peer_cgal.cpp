// CGAL peers of the benchmark: jet_estimate_normals (jet fitting, Cazals & Pouget) and
// vcm_estimate_normals (Voronoi covariance measure, Merigot et al.).
#include "peers.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/compute_average_spacing.h>
#include <CGAL/jet_estimate_normals.h>
#include <CGAL/property_map.h>
#include <CGAL/vcm_estimate_normals.h>

#ifdef CGAL_LINKED_WITH_TBB
#include <tbb/global_control.h>
#endif

#include <algorithm>
#include <cmath>
#include <memory>
#include <utility>
#include <vector>

namespace nhnet_bench {
namespace {

// Exact predicates: VCM builds a Delaunay triangulation, which crashes with inexact predicates.
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using PointNormal = std::pair<Point, Vector>;
using PointMap = CGAL::First_of_pair_property_map<PointNormal>;
using NormalMap = CGAL::Second_of_pair_property_map<PointNormal>;

std::vector<PointNormal> to_cgal(const nhnet::Points& points) {
  std::vector<PointNormal> pts(size_t(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    pts[size_t(i)].first = Point(points(i, 0), points(i, 1), points(i, 2));
  return pts;
}

nhnet::Normals from_cgal(const std::vector<PointNormal>& pts) {
  nhnet::Normals n(Eigen::Index(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) {
    const Vector& v = pts[i].second;
    n.row(Eigen::Index(i)) << v.x(), v.y(), v.z();
  }
  return n;
}

// Median distance from a point to its k-th nearest neighbour (self included), over at most 2000
// evenly strided points: the radius that holds about k points.
double median_knn_radius(const std::vector<PointNormal>& pts, int k) {
  using Traits = CGAL::Search_traits_3<Kernel>;
  using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
  Search::Tree tree;
  for (const auto& p : pts) tree.insert(p.first);
  tree.build();
  const size_t step = std::max<size_t>(1, pts.size() / 2000);
  std::vector<double> r;
  for (size_t i = 0; i < pts.size(); i += step) {
    Search search(tree, pts[i].first, unsigned(k));
    double d2 = 0;
    for (const auto& nb : search) d2 = std::max(d2, nb.second);
    r.push_back(std::sqrt(d2));
  }
  std::nth_element(r.begin(), r.begin() + long(r.size() / 2), r.end());
  return r[r.size() / 2];
}

}  // namespace

nhnet::Normals cgal_jet_normals(const nhnet::Points& points, int k, int threads) {
#ifdef CGAL_LINKED_WITH_TBB
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
#endif
  std::vector<PointNormal> pts = to_cgal(points);
  CGAL::jet_estimate_normals<CGAL::Parallel_if_available_tag>(
      pts, unsigned(k), CGAL::parameters::point_map(PointMap()).normal_map(NormalMap()));
  return from_cgal(pts);
}

nhnet::Normals cgal_vcm_normals(const nhnet::Points& points, int k, double offset_spacings,
                                int threads) {
#ifdef CGAL_LINKED_WITH_TBB
  tbb::global_control limit(tbb::global_control::max_allowed_parallelism, size_t(threads));
#endif
  std::vector<PointNormal> pts = to_cgal(points);
  const double spacing = CGAL::compute_average_spacing<CGAL::Parallel_if_available_tag>(
      pts, 6, CGAL::parameters::point_map(PointMap()));
  // The radius overload, not the k-neighbour one: CGAL 5.5's k-neighbour convolution sums into
  // an uninitialised std::array (vcm_convolve, "Covariance m;") and returns garbage normals.
  const double convolution_radius = median_knn_radius(pts, k);
  CGAL::vcm_estimate_normals(pts, offset_spacings * spacing, convolution_radius,
                             CGAL::parameters::point_map(PointMap()).normal_map(NormalMap()));
  return from_cgal(pts);
}

}  // namespace nhnet_bench
