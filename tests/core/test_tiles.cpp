// The tiled run's steps one at a time (core/src/pipeline/tiles.cpp), driven as nhnet.distributed
// drives them: a plan on a sample, the points routed to tiles, the probe and the surface
// variation tile by tile, the decisions once, each tile with its halo; the normals are the
// untiled run's. Bad plans are refused.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/tiles.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace nhnet;

namespace {

struct Tiled {
  Points frame_pts;
  std::vector<int32_t> tile;
  TilePlan plan;
  std::vector<Eigen::RowVector3d> lo, hi;
};

// Tile t's own points (input order) then the other tiles' points within `halo` of its box.
Points with_halo(const Tiled& tl, int t, double halo, int64_t& own, std::vector<int64_t>& rows) {
  rows.clear();
  for (Eigen::Index i = 0; i < tl.frame_pts.rows(); ++i)
    if (tl.tile[size_t(i)] == t) rows.push_back(i);
  own = int64_t(rows.size());
  const Eigen::RowVector3d lo = tl.lo[size_t(t)].array() - halo;
  const Eigen::RowVector3d hi = tl.hi[size_t(t)].array() + halo;
  for (Eigen::Index i = 0; i < tl.frame_pts.rows(); ++i)
    if (tl.tile[size_t(i)] != t && (tl.frame_pts.row(i).array() >= lo.array()).all() &&
        (tl.frame_pts.row(i).array() <= hi.array()).all())
      rows.push_back(i);
  Points p(Eigen::Index(rows.size()), 3);
  for (size_t r = 0; r < rows.size(); ++r) p.row(Eigen::Index(r)) = tl.frame_pts.row(rows[r]);
  return p;
}

Tiled cut(const Points& pts, int64_t tile_points) {
  Tiled tl;
  const TileFrame f = tile_frame(pts.colwise().minCoeff(), pts.colwise().maxCoeff());
  tl.frame_pts = (pts.rowwise() - f.centre) * f.scale;
  Points sample(pts.rows() / 3, 3);
  for (Eigen::Index i = 0; i < sample.rows(); ++i) sample.row(i) = tl.frame_pts.row(3 * i);
  tl.plan = plan_tiles(sample, pts.rows(), tile_points);
  tl.tile = route_tiles(tl.plan, tl.frame_pts);
  const size_t n = size_t(tl.plan.cell_lo.rows());
  tl.lo.assign(n, Eigen::RowVector3d::Constant(1e300));
  tl.hi.assign(n, Eigen::RowVector3d::Constant(-1e300));
  for (Eigen::Index i = 0; i < pts.rows(); ++i) {
    const size_t t = size_t(tl.tile[size_t(i)]);
    tl.lo[t] = tl.lo[t].cwiseMin(tl.frame_pts.row(i));
    tl.hi[t] = tl.hi[t].cwiseMax(tl.frame_pts.row(i));
  }
  return tl;
}

TileDecisions probe_pass(const Tiled& tl, const EstimateOptions& o, bool rough, double halo) {
  std::vector<TileProbeRows> rows;
  std::vector<int64_t> r;
  int64_t own = 0;
  for (int t = 0; t < int(tl.lo.size()); ++t) {
    const Points p = with_halo(tl, t, halo, own, r);
    rows.push_back(probe_tile(p, own, probe_step(tl.frame_pts.rows(), rough), halo,
                              tl.plan.cell_lo.row(t), tl.plan.cell_hi.row(t), 2));
  }
  return decide_tiles(rows, o, tl.frame_pts.rows());
}

}  // namespace

// 4 tiles of a noisy cube (faces and edges cut): same sizes and (up to rounding) candidates as
// the untiled run, and the normals within 0.5 degrees for 99.9 % of the points (only rounding
// differs: each tile is re-centred before its float kd-tree).
TEST(Tiles, StepByStepEqualsTheUntiledRun) {
  const auto f = fixtures::cube(30000, 0.004, 11);
  EstimateOptions o;
  o.method = Method::Mfps;
  o.run.threads = 2;
  o.tiles.points = 0;
  const EstimateResult whole = estimate_normals(f.points, o);
  const Tiled tl = cut(f.points, 8000);
  ASSERT_EQ(tl.lo.size(), 4u);
  const TileDecisions rough = probe_pass(tl, o, true, 0);
  TileDecisions d = probe_pass(tl, o, false, 2 * rough.far_radius);
  EXPECT_EQ(d.k_smooth, whole.k_used);
  EXPECT_EQ(d.scales, whole.scales_used);
  EXPECT_NEAR(d.noise_ratio, whole.noise_ratio, 1e-6 * whole.noise_ratio);
  std::vector<double> variation;
  std::vector<int64_t> rows;
  int64_t own = 0;
  for (int t = 0; t < 4; ++t) {
    const Eigen::VectorXd v =
        tile_variation(with_halo(tl, t, d.variation_halo, own, rows), own, d.k_smooth, 1, 2);
    variation.insert(variation.end(), v.data(), v.data() + v.size());
  }
  d.variation_threshold = variation_threshold(
      Eigen::Map<const Eigen::VectorXd>(variation.data(), Eigen::Index(variation.size())));
  Normals tiled = Normals::Constant(f.points.rows(), 3, std::nan(""));
  int64_t candidates = 0;
  for (int t = 0; t < 4; ++t) {
    const EstimateResult r = estimate_tile(with_halo(tl, t, d.halo, own, rows), o, d);
    for (int64_t i = 0; i < own; ++i) {
      tiled.row(rows[size_t(i)]) = r.normals.row(i);
      candidates += r.candidate[size_t(i)];
    }
  }
  // A point whose surface variation sits on the threshold can change side by rounding (as in
  // the in-memory tiling's test: 0.1 % of the points).
  EXPECT_NEAR(double(candidates), double(whole.candidates), 0.001 * 30000);
  const Eigen::VectorXd e = angle_errors_deg(whole.normals, tiled);
  EXPECT_GE(double((e.array() <= 0.5).count()) / double(e.size()), 0.999);
}

TEST(Tiles, RouteRefusesABrokenPlan) {
  TilePlan p;
  p.axis = {0};
  p.value = {0.0};
  p.left = {5};
  p.right = {5};
  p.leaf = {-1};
  EXPECT_THROW(route_tiles(p, Points::Zero(1, 3)), InvalidOptions);
  EXPECT_THROW(plan_tiles(Points::Zero(10, 3), 10, 0), InvalidOptions);
}
