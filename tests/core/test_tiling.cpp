// Spatial tiling (core/src/pipeline/tiling.cpp): a cloud processed in tiles with halos gets the
// normals of the untiled run, for PCA, MFPS and NH-Net; non-finite points and duplicates across
// tile borders are handled like the untiled run; progress reaches 1 and cancellation stops it.
#include "fixtures.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/learned/nhnet_model.hpp"
#include "nhnet/pipeline/estimate.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

using namespace nhnet;

namespace {

// Share of rows whose (unoriented) normals differ by more than `deg` degrees; rows invalid in
// both count as equal.
double share_differing(const EstimateResult& a, const EstimateResult& b, double deg) {
  const Eigen::VectorXd e = angle_errors_deg(a.normals, b.normals);
  int64_t bad = 0;
  for (Eigen::Index i = 0; i < e.size(); ++i) {
    if (!a.valid[size_t(i)] && !b.valid[size_t(i)]) continue;
    if (a.valid[size_t(i)] != b.valid[size_t(i)] || !(e[i] <= deg)) ++bad;
  }
  return double(bad) / double(e.size());
}

// Tiles of `tile_points` (0: none); memory 0 tiles whatever the memory they save.
EstimateResult run(const Points& p, EstimateOptions o, int64_t tile_points, int64_t memory = 0) {
  o.tiles.points = tile_points;
  o.tiles.memory = memory;
  o.run.threads = 2;
  return estimate_normals(p, o);
}

// The whole cloud's decisions, which a tiled run hands every tile: sizes, noise, spacing
// (exactly: the same probe of the same canonical points).
void expect_same_decisions(const EstimateResult& a, const EstimateResult& b) {
  EXPECT_EQ(a.k_used, b.k_used);
  EXPECT_EQ(a.scales_used, b.scales_used);
  EXPECT_EQ(a.noise_ratio, b.noise_ratio);
  EXPECT_EQ(a.spacing, b.spacing);
}

}  // namespace

// The cube's 4 tiles cut through faces and edges; each tile gets the whole cloud's noise level,
// sizes and candidate threshold, and its halo holds every neighbourhood its points use, so the
// tiled normals are the untiled ones. Only floating-point rounding differs (each tile is
// re-centred before its float kd-tree), which can swap equidistant neighbours: 1e-3 degrees for
// 99.5 % of the points, and no accuracy lost against the ground truth (0.05 degrees on a mean of
// ~2-5 degrees).
TEST(Tiling, MfpsTilesEqualTheUntiledRun) {
  const auto f = fixtures::cube(30000, 0.004, 11);
  EstimateOptions o;
  o.method = Method::Mfps;
  const EstimateResult whole = run(f.points, o, 0);
  const EstimateResult tiled = run(f.points, o, 8000);
  EXPECT_EQ(whole.tiles, 1);
  EXPECT_EQ(tiled.tiles, 4);
  expect_same_decisions(tiled, whole);
  EXPECT_EQ(tiled.failed, whole.failed);
  EXPECT_GT(whole.candidates, 1000);
  EXPECT_NEAR(double(tiled.candidates), double(whole.candidates), 0.001 * 30000);
  EXPECT_LT(share_differing(tiled, whole, 1e-3), 0.005);
  const double ew = angle_stats(whole.normals, f.normals).mean;
  const double et = angle_stats(tiled.normals, f.normals).mean;
  EXPECT_NEAR(et, ew, 0.05);
}

// Over `points` but within the memory budget (TileOptions::memory) a cloud stays in one piece,
// after the tiling's noise probe: exactly the untiled run's normals and sizes. A budget the
// estimate exceeds (30 000 points need several MB; 1 MiB here) tiles it as before.
TEST(Tiling, InOnePieceWhileTheMemoryBudgetHolds) {
  const auto f = fixtures::cube(30000, 0.004, 11);
  EstimateOptions o;
  o.method = Method::Mfps;
  const EstimateResult whole = run(f.points, o, 0);
  const EstimateResult fits = run(f.points, o, 8000, EstimateOptions{}.tiles.memory);  // GiB
  EXPECT_EQ(fits.tiles, 1);
  expect_same_decisions(fits, whole);
  EXPECT_EQ(fits.candidates, whole.candidates);
  ASSERT_EQ(fits.valid, whole.valid);
  for (Eigen::Index i = 0; i < f.points.rows(); ++i)
    if (whole.valid[size_t(i)]) {
      ASSERT_EQ(fits.normals.row(i), whole.normals.row(i)) << i;
    }
  EXPECT_EQ(run(f.points, o, 8000, int64_t(1) << 20).tiles, 4);
}

// Too small a halo must show: with a halo of a tenth of a neighbourhood radius the points at the
// tile borders lose neighbours (so the equality above is the halo's doing, not luck).
TEST(Tiling, TooSmallAHaloChangesTheBorderPoints) {
  const auto f = fixtures::cube(30000, 0.004, 11);
  EstimateOptions o;
  o.method = Method::Mfps;
  const EstimateResult whole = run(f.points, o, 0);
  o.tiles.halo = 0.1;
  const EstimateResult tiled = run(f.points, o, 8000);
  EXPECT_GT(share_differing(tiled, whole, 1e-3), 0.01);
}

TEST(Tiling, PcaWithNonFiniteAndDuplicatePoints) {
  auto f = fixtures::sphere(12000, 3);
  Points p(f.points.rows() + 300, 3);
  p.topRows(f.points.rows()) = f.points;
  for (int i = 0; i < 300; ++i) {
    if (i % 3 == 0) {
      p.row(f.points.rows() + i).setConstant(std::numeric_limits<double>::quiet_NaN());
    } else {
      p.row(f.points.rows() + i) = f.points.row((i * 37) % f.points.rows());  // a duplicate
    }
  }
  EstimateOptions o;
  o.method = Method::Pca;
  const EstimateResult whole = run(p, o, 0);
  const EstimateResult tiled = run(p, o, 3000);
  EXPECT_EQ(tiled.tiles, 4);
  EXPECT_EQ(tiled.failed, 100);
  EXPECT_EQ(whole.failed, 100);
  EXPECT_EQ(tiled.valid, whole.valid);
  EXPECT_EQ(tiled.warnings, whole.warnings);
  EXPECT_LT(share_differing(tiled, whole, 1e-3), 0.005);
  for (int i = 0; i < 300; ++i) {
    if (i % 3 != 0) {
      EXPECT_EQ(tiled.normals.row(f.points.rows() + i),
                tiled.normals.row((i * 37) % f.points.rows()));
    }
  }
}

TEST(Tiling, ProgressReachesOneAndCancelStops) {
  const auto f = fixtures::cube(12000, 0.004, 2);
  EstimateOptions o;
  o.method = Method::Mfps;
  o.tiles.points = 4000;
  o.tiles.memory = 0;
  o.run.threads = 2;
  double last = -1;
  bool monotone = true;
  o.run.progress = [&](double x, const std::string&) {
    monotone = monotone && x >= last - 1e-12;
    last = x;
    return true;
  };
  estimate_normals(f.points, o);
  EXPECT_TRUE(monotone);
  EXPECT_DOUBLE_EQ(last, 1.0);
  // Cancel once the second tile has started: the call throws, nothing half-done comes back.
  o.run.progress = [](double x, const std::string&) { return x < 0.5; };
  EXPECT_THROW(estimate_normals(f.points, o), Cancelled);
}

// NH-Net: descriptors read the neighbours' MFPS normals, one neighbourhood further out; the
// halo (4 radii) covers that too. Tiny model of the golden test (speed); 1e-3 degrees as above
// (float32 model on the same inputs).
TEST(Tiling, NhNetTilesEqualTheUntiledRun) {
  ASSERT_TRUE(nhnet_available());  // CI installs libtorch-dev
  const auto f = fixtures::cube(9000, 0.004, 4);
  EstimateOptions o;
  o.method = Method::NhNet;
  o.model.path = std::string(NHNET_SOURCE_DIR) + "/tests/data/nhnet_tiny.pt";
  o.model.device = "cpu";
  const EstimateResult whole = run(f.points, o, 0);
  const EstimateResult tiled = run(f.points, o, 3000);
  EXPECT_EQ(tiled.tiles, 3);
  EXPECT_EQ(tiled.descriptor_k, whole.descriptor_k);
  EXPECT_EQ(tiled.device_used, "cpu");
  EXPECT_EQ(tiled.precision_used, "float32");
  EXPECT_LT(share_differing(tiled, whole, 1e-3), 0.005);
}

// The cell-mean decision (CellMeanOptions::min_points lowered to reach these clouds; their noise
// ratio stays under its threshold, so the points themselves are estimated) builds the canonical
// points, their tree and the probe; the estimate after it, tiled or in one piece, takes them over
// instead of building them again. Same normals, bit for bit, as without the decision, for
// MFPS's tiles, MFPS in one piece after the tiling's memory check, and NH-Net (its rows along a
// Morton curve: the decision's canonical rows renumbered, row_order.hpp).
TEST(Tiling, TheCellMeanDecisionsPreparedPointsServeTheEstimate) {
  const auto f = fixtures::cube(30000, 0.004, 11);
  const auto same = [&](EstimateOptions o, int64_t tile_points, int64_t memory) {
    o.cell_means.noise_ratio = 0;  // no decision: the estimate builds its own
    const EstimateResult own = run(f.points, o, tile_points, memory);
    o.cell_means = CellMeanOptions{};
    o.cell_means.min_points = 1000;
    const EstimateResult taken = run(f.points, o, tile_points, memory);
    ASSERT_LT(taken.noise_ratio, o.cell_means.noise_ratio);  // not averaged
    EXPECT_EQ(taken.tiles, own.tiles);
    expect_same_decisions(taken, own);
    ASSERT_EQ(taken.valid, own.valid);
    for (Eigen::Index i = 0; i < f.points.rows(); ++i)
      if (own.valid[size_t(i)]) {
        ASSERT_EQ(taken.normals.row(i), own.normals.row(i)) << i;
      }
    EXPECT_EQ(taken.warnings, own.warnings);
  };
  EstimateOptions o;
  o.method = Method::Mfps;
  same(o, 8000, 0);                               // tiles
  same(o, 8000, EstimateOptions{}.tiles.memory);  // one piece after the memory check
  same(o, 0, 0);                                  // untiled
  ASSERT_TRUE(nhnet_available());
  o.method = Method::NhNet;
  o.model.path = std::string(NHNET_SOURCE_DIR) + "/tests/data/nhnet_tiny.pt";
  o.model.device = "cpu";
  same(o, 0, 0);
  same(o, 8000, EstimateOptions{}.tiles.memory);
}
