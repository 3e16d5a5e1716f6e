// Inside / outside votes of the flood fill (core/src/orient/inside_outside.hpp): outward normals of
// closed surfaces (sphere, noisy cube, thin slab) vote +1 and their negatives -1, a normal
// tangent to the surface gets no vote, an open surface has no watertight grid and no votes.
#include "fixtures.hpp"

#include "orient/inside_outside.hpp"

#include <gtest/gtest.h>

using nhnet::Normals;
using nhnet::Points;
using nhnet::detail::InsideOutside;

namespace {

// Mean distance to the nearest other point.
double spacing(const Points& pts) {
  const nhnet::IndexMatrix knn = fixtures::knn_table(pts, 2);
  double s = 0;
  for (Eigen::Index i = 0; i < pts.rows(); ++i) s += (pts.row(knn(i, 1)) - pts.row(i)).norm();
  return s / double(pts.rows());
}

// Shares of +1 and -1 votes.
std::pair<double, double> shares(const std::vector<int8_t>& votes) {
  double plus = 0, minus = 0;
  for (const int8_t v : votes) {
    plus += v > 0;
    minus += v < 0;
  }
  return {plus / double(votes.size()), minus / double(votes.size())};
}

}  // namespace

TEST(InsideOutside, ClosedSurfacesVoteOutward) {
  // Each closed fixture: every outward normal decided +1 (0.999: a handful of points in a
  // cube's corners may stay undecided, none may vote wrong), every inward one -1.
  const fixtures::Fixture closed[] = {fixtures::sphere(20000, 1), fixtures::cube(20000, 0.01, 2),
                                      fixtures::slab(20000, 0.02, 0.002, 3)};
  for (const fixtures::Fixture& f : closed) {
    const double s = spacing(f.points);
    const InsideOutside out(f.points, f.normals, s);
    ASSERT_GT(out.voxel(), 0.0);
    EXPECT_LT(out.leak(), 0.05);
    EXPECT_GE(shares(out.votes()).first, 0.999);
    EXPECT_EQ(shares(out.votes()).second, 0.0);
    const Normals inward = -f.normals;
    const InsideOutside in(f.points, inward, s);
    EXPECT_GE(shares(in.votes()).second, 0.999);
    EXPECT_EQ(shares(in.votes()).first, 0.0);
    // The single-normal query agrees with the votes, and a normal tangent to the sphere's
    // surface (both offsets stay in the occupied shell or both leave it) gets none.
    EXPECT_EQ(out.vote(f.points.row(0), f.normals.row(0)), out.votes()[0]);
  }
  const fixtures::Fixture s = fixtures::sphere(20000, 1);
  const InsideOutside out(s.points, s.normals, spacing(s.points));
  const Eigen::RowVector3d p(1, 0, 0), tangent(0, 0, 1);
  EXPECT_EQ(out.vote(p, tangent), 0);
  EXPECT_EQ(out.vote(p, Eigen::RowVector3d(1, 0, 0)), 1);
  EXPECT_EQ(out.vote(p, Eigen::RowVector3d(-1, 0, 0)), -1);
}

TEST(InsideOutside, OpenSurfaceHasNoWatertightGrid) {
  const fixtures::Fixture f = fixtures::plane(10000, 5);
  const InsideOutside io(f.points, f.normals, spacing(f.points));
  EXPECT_EQ(io.voxel(), 0.0);
  EXPECT_GE(io.leak(), 0.05);
  EXPECT_EQ(shares(io.votes()).first + shares(io.votes()).second, 0.0);
  EXPECT_EQ(io.vote(f.points.row(0), f.normals.row(0)), 0);
}

TEST(InsideOutside, TooFewPointsOrNoSpacingGiveNoVotes) {
  // Also a sphere whose extent overflows double (radius 1e308): no grid, no votes, no crash.
  fixtures::Fixture huge = fixtures::sphere(1000, 2);
  huge.points *= 1e308;
  const InsideOutside none(huge.points, huge.normals, 1e306);
  EXPECT_EQ(none.voxel(), 0.0);
  EXPECT_EQ(shares(none.votes()).first + shares(none.votes()).second, 0.0);
  const fixtures::Fixture f = fixtures::sphere(3, 1);
  EXPECT_EQ(InsideOutside(f.points, f.normals, 0.1).voxel(), 0.0);
  const fixtures::Fixture g = fixtures::sphere(100, 1);
  EXPECT_EQ(InsideOutside(g.points, g.normals, 0.0).voxel(), 0.0);
}

// One far outlier stretches the box so that even a 384^3 grid has voxels of many spacings: with
// the typical (median) spacing known, no grid is built (no votes; orientation falls back to the
// tree) instead of filling a grid that cannot resolve the sphere; a sphere without the outlier
// still gets its grid with the same option.
TEST(InsideOutside, FarOutlierGetsNoGrid) {
  const auto f = fixtures::sphere(4000, 7);
  Points p(f.points.rows() + 1, 3);
  p.topRows(f.points.rows()) = f.points;
  p.row(f.points.rows()) << 1000, 1000, 1000;
  Normals n(p.rows(), 3);
  n.topRows(f.points.rows()) = f.normals;
  n.row(f.points.rows()) << 0, 0, 1;
  nhnet::detail::InsideOutsideOptions o;
  o.typical_spacing = spacing(f.points);
  const InsideOutside far(p, n, spacing(p), o);
  EXPECT_EQ(far.grids_built(), 0);
  EXPECT_EQ(far.voxel(), 0.0);
  EXPECT_EQ(shares(far.votes()).first + shares(far.votes()).second, 0.0);
  const InsideOutside near(f.points, f.normals, spacing(f.points), o);
  EXPECT_GE(near.grids_built(), 1);
  EXPECT_GT(near.voxel(), 0.0);
  EXPECT_GE(shares(near.votes()).first, 0.999);
}

TEST(InsideOutside, OneMoreDilationBeforeACoarserVoxel) {
  // A sphere with a band 6 spacings wide cut out around its equator: the fill leaks through
  // the band unless the dilation closes it. With the dilation of 2 alone the first watertight
  // grid is 2.5 spacings (measured 2.5); trying a dilation of 3 at each voxel first closes it
  // at 2 spacings (measured), the finer grid that resolves thin parts (rotor's blades). The
  // votes stay right: every decided normal outward.
  const fixtures::Fixture f = fixtures::sphere(40000, 1);
  const double s = spacing(f.points);
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < f.points.rows(); ++i)
    if (std::abs(f.points(i, 2)) > 3 * s) keep.push_back(i);
  const Points p = f.points(keep, Eigen::all);
  const Normals n = f.normals(keep, Eigen::all);
  nhnet::detail::InsideOutsideOptions two;
  two.dilations = {2};
  const InsideOutside both(p, n, s), only_two(p, n, s, two);
  ASSERT_GT(both.voxel(), 0.0);
  ASSERT_GT(only_two.voxel(), 0.0);
  EXPECT_LE(both.voxel(), 2.0 * s * (1 + 1e-9));
  EXPECT_GE(only_two.voxel(), 2.5 * s * (1 - 1e-9));
  EXPECT_GE(shares(both.votes()).first, 0.999);
  EXPECT_EQ(shares(both.votes()).second, 0.0);

  // At each voxel the smaller dilation comes first: a grid watertight with it (the cube at
  // 2.5 spacings) is used as it is, with its votes, whatever dilations follow it.
  const fixtures::Fixture cube = fixtures::cube(20000, 0.01, 2);
  const double sc = spacing(cube.points);
  nhnet::detail::InsideOutsideOptions coarse, coarse_two;
  coarse.voxel_spacings = coarse_two.voxel_spacings = {2.5};
  coarse_two.dilations = {2};
  const InsideOutside a(cube.points, cube.normals, sc, coarse),
      b(cube.points, cube.normals, sc, coarse_two);
  ASSERT_GT(b.voxel(), 0.0);
  EXPECT_EQ(a.voxel(), b.voxel());
  EXPECT_EQ(a.votes(), b.votes());
}
