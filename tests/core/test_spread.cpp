// util/spread.hpp: the fixed-size subset of a large neighbourhood that MFPS's patch fits and
// the residual bandwidth take (issue 23: cost per point flat in the noise-driven k).
#include "util/spread.hpp"

#include <gtest/gtest.h>

using nhnet::detail::spread_count;
using nhnet::detail::spread_rank;

TEST(Spread, CountCapsOnlyLargeNeighbourhoods) {
  EXPECT_EQ(spread_count(300, 128), 128);
  EXPECT_EQ(spread_count(100, 128), 100);  // smaller than the cap: all members
  EXPECT_EQ(spread_count(300, 0), 300);    // 0: all members
  EXPECT_EQ(spread_count(128, 128), 128);
}

TEST(Spread, RanksRunFromTheCentreToTheFarthestEvenly) {
  for (const int k : {5, 64, 65, 129, 250, 300}) {
    for (const int m : {2, 3, 17, 64, 128}) {
      if (m > k) continue;
      EXPECT_EQ(spread_rank(0, m, k), 0);
      EXPECT_EQ(spread_rank(m - 1, m, k), k - 1) << "k " << k << " m " << m;
      const double step = double(k - 1) / (m - 1);
      for (int t = 1; t < m; ++t) {
        const int gap = spread_rank(t, m, k) - spread_rank(t - 1, m, k);
        EXPECT_GE(gap, 1) << "ranks repeat at k " << k << " m " << m << " t " << t;
        // rounded to the nearest rank: every gap is the even step rounded down or up
        EXPECT_LE(std::abs(gap - step), 1.0) << "k " << k << " m " << m << " t " << t;
      }
    }
  }
}

TEST(Spread, AllMembersKeepTheirOrder) {
  for (int t = 0; t < 50; ++t) EXPECT_EQ(spread_rank(t, 50, 50), t);
}
