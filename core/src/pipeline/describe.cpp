// The descriptor chain of a whole cloud (paper Sec. 5.1; describe.hpp): the geometry stage, then
// the descriptor neighbourhoods and the descriptors of every point that got a normal.
#include "nhnet/pipeline/describe.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/neighbors/neighbors.hpp"
#include "pipeline/estimator.hpp"
#include "util/parallel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace nhnet {

int descriptor_k(int kmin, const DescriptorOptions& options, Eigen::Index m) {
  return int(std::min<Eigen::Index>(
      m, std::max(options.filter.spacing_k + 1,
                  int(std::ceil(options.neighborhood_factor * kmin - 1e-9)))));
}

int descriptor_k_of_scales(const std::vector<int>& scales, const DescriptorOptions& options,
                           Eigen::Index m) {
  int kmin = scales.empty() ? kDescriptorScaleWithoutMfps : std::numeric_limits<int>::max();
  for (int s : scales) kmin = std::min<int>(kmin, int(std::min<Eigen::Index>(s, m)));
  return descriptor_k(kmin, options, m);
}

namespace detail {

EstimateOptions geometry_options(const EstimateOptions& options, bool pca_blend) {
  EstimateOptions eo = options;
  eo.method = Method::Mfps;
  eo.mfps.pca_blend = pca_blend;
  eo.run = narrow(options.run, 0, 0.9);
  return eo;
}

namespace {

/// Positions in `base` (input rows in the order the points will follow) of the rows with a normal,
/// the described ones (all, or those flagged in `only`) first; sets `described`.
std::vector<int64_t> described_first(const std::vector<int64_t>& base,
                                     const std::vector<uint8_t>& valid,
                                     const std::vector<uint8_t>* only, Eigen::Index& described) {
  std::vector<int64_t> order;
  for (size_t i = 0; i < base.size(); ++i)
    if (valid[size_t(base[i])] && (!only || (*only)[size_t(base[i])])) order.push_back(int64_t(i));
  described = Eigen::Index(order.size());
  if (only)  // the other points with a normal follow: neighbours, not described
    for (size_t i = 0; i < base.size(); ++i)
      if (valid[size_t(base[i])] && !(*only)[size_t(base[i])]) order.push_back(int64_t(i));
  return order;
}

/// The geometry stage's table usable for `in`: filled, deep enough, and every canonical point has
/// a normal (the descriptors' neighbours are the points with one).
bool table_serves(const SharedTable* table, const DescriptorInput& in, Eigen::Index points) {
  return table && !table->rows.empty() && table->knn.cols() >= in.k &&
         Eigen::Index(in.rows.size()) == points;
}

/// The described rows of `table` in the order of `order` (positions in the canonical points),
/// its first k columns renumbered to positions in that order; the whole table, moved, when the
/// order is the canonical one.
void take_table(SharedTable& table, const std::vector<int64_t>& order, DescriptorInput& in) {
  if (in.described == Eigen::Index(order.size())) {  // every point described: canonical order
    in.knn = std::move(table.knn);
    return;
  }
  std::vector<int32_t> pos(order.size());
  for (size_t r = 0; r < order.size(); ++r) pos[size_t(order[r])] = int32_t(r);
  in.knn.resize(in.described, in.k);
  for (Eigen::Index r = 0; r < in.described; ++r)
    for (Eigen::Index j = 0; j < in.k; ++j)
      in.knn(r, j) = pos[size_t(table.knn(order[size_t(r)], j))];
}

}  // namespace

DescriptorInput descriptor_input(const Points& points, EstimateResult geometry,
                                 const DescriptorOptions& options, const RunContext& run,
                                 const std::vector<uint8_t>* only, SharedTable* table) {
  DescriptorInput in;
  in.geometry = std::move(geometry);
  const bool canonical = table && !table->rows.empty();
  std::vector<int64_t> base = canonical ? table->rows : std::vector<int64_t>(size_t(points.rows()));
  if (!canonical) std::iota(base.begin(), base.end(), int64_t(0));
  const std::vector<int64_t> order = described_first(base, in.geometry.valid, only, in.described);
  for (int64_t i : order) in.rows.push_back(Eigen::Index(base[size_t(i)]));
  const Eigen::Index m = Eigen::Index(in.rows.size());
  if (m <= options.filter.spacing_k) {
    in.geometry.warnings.push_back("too few points with a normal for descriptors");
    in.rows.clear();
    in.described = 0;
    return in;
  }
  in.points.resize(m, 3);
  in.normals.resize(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    in.points.row(i) = points.row(in.rows[size_t(i)]);
    in.normals.row(i) = in.geometry.normals.row(in.rows[size_t(i)]);
  }
  in.k = descriptor_k_of_scales(in.geometry.scales_used, options, m);
  if (table_serves(table, in, Eigen::Index(base.size()))) {
    take_table(*table, order, in);
    return in;
  }
  Neighbors tree(in.points);
  if (in.described == m) {
    tree.knn_all(in.k, in.knn, nullptr, run);
  } else {
    std::vector<int64_t> first(size_t(in.described));
    std::iota(first.begin(), first.end(), int64_t(0));
    tree.knn_rows(in.k, first, in.knn, nullptr, run);
  }
  return in;
}

}  // namespace detail

DescriptorInput prepare_descriptors(const Points& points, const DescribeOptions& options) {
  if (!(options.descriptor.neighborhood_factor > 0))
    throw InvalidOptions("descriptor neighborhood factor must be > 0");
  const EstimateOptions eo = detail::geometry_options(options.estimate, options.mfps_pca_blend);
  const RunContext rest = detail::narrow(options.estimate.run, 0.9, 1);
  if (detail::wants_tiles(points, eo))
    return detail::descriptor_input(points, estimate_normals(points, eo), options.descriptor, rest);
  detail::check_options(eo);  // as estimate_normals; one search for geometry and descriptors
  detail::SharedTable table{options.descriptor, {}, {}};
  EstimateResult geometry = detail::estimate_geometry(points, eo, {}, nullptr, &table);
  return detail::descriptor_input(points, std::move(geometry), options.descriptor, rest, nullptr,
                                  &table);
}

Descriptors describe(const Points& points, const DescribeOptions& options) {
  DescribeOptions o = options;
  o.estimate.run = detail::narrow(options.estimate.run, 0, 0.8);
  DescriptorInput in = prepare_descriptors(points, o);
  Descriptors out;
  const Eigen::Index n = points.rows();
  out.features.setConstant(n, descriptor_size(options.descriptor),
                           std::numeric_limits<float>::quiet_NaN());
  out.rotations.setConstant(n, 9, std::numeric_limits<double>::quiet_NaN());
  out.k_used = in.k;
  if (!in.rows.empty()) {
    DescriptorMatrix feat;
    Rotations rot;
    compute_descriptors(in.points, in.normals, in.knn, in.k, options.descriptor, feat, rot,
                        detail::narrow(options.estimate.run, 0.8, 1));
    for (size_t i = 0; i < in.rows.size(); ++i) {
      out.features.row(in.rows[i]) = feat.row(Eigen::Index(i));
      out.rotations.row(in.rows[i]) = rot.row(Eigen::Index(i));
    }
  }
  out.geometry = std::move(in.geometry);
  return out;
}

}  // namespace nhnet
