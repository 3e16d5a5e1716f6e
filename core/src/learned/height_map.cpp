// Height-map patches (paper Eq. 6); see height_map.hpp.
#include "nhnet/learned/height_map.hpp"

#include "nhnet/errors.hpp"
#include "util/fast_math.hpp"
#include "util/parallel.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace nhnet {

namespace {

/// floor and ceil of x as an int, for |x| well inside int's range (cell coordinates, which the
/// map's radius bounds by m): a truncation and a compare, where std::floor is a call into libm
/// on a baseline x86-64 build (no SSE4.1 round instruction), four per neighbour and frame.
inline int floor_int(double x) {
  const int t = int(x);
  return t - int(x < double(t));
}
inline int ceil_int(double x) {
  const int t = int(x);
  return t + int(x > double(t));
}

/// A point's neighbours relative to it, as three coordinate arrays (per thread, reused).
struct Offsets {
  std::vector<double> x, y, z;

  void resize(size_t n) {
    x.resize(n);
    y.resize(n);
    z.resize(n);
  }
  /// (v . a) * s of every offset v into out, each dot in the order of Eigen's Vector3d dot,
  /// ((x a0 + y a1) + z a2), so the values are those of v.dot(a) * s bit for bit; on columns,
  /// so that the loop vectorises.
  void project(const Eigen::Vector3d& a, double s, double* out) const {
    const double a0 = a[0], a1 = a[1], a2 = a[2];
    for (size_t j = 0; j < x.size(); ++j) out[j] = ((x[j] * a0 + y[j] * a1) + z[j] * a2) * s;
  }
};

/// The ball-cell pairs of one height map before their weights (per thread, reused: sized once
/// for the largest neighbourhood, so no allocation per point).
struct Contributions {
  std::vector<int> cell;           // row-major cell index
  std::vector<double> dist2;       // squared distance to the cell centre, in cells
  std::vector<double> height;      // the neighbour's height, in cells
  std::vector<double> weight;      // exp(-dist2 / 2)
  size_t count = 0;                // pairs in use
  std::vector<double> hz, hu, hw;  // per neighbour: height and map coordinates, in cells
  std::vector<uint32_t> near;      // the neighbours within the ball's height

  /// The pair (neighbour at u, w, height z; cell rr, cc) when within the ball (branch-free:
  /// written always, kept by advancing the count).
  void add_pair(double u, double w, double z, double z2, int rr, int cc, int m, double ball2) {
    const double e2 = (u - rr) * (u - rr) + (w - cc) * (w - cc) + z2;
    cell[count] = rr * m + cc;
    dist2[count] = e2;
    height[count] = z;
    count += size_t(!(e2 > ball2));
  }
  /// The pairs of a neighbour whose cells span at most 2 x 2 (a ball below one cell): rows
  /// r0..r1 and columns c0..c1 as the general loop, without its loop control.
  void add_block2(double u, double w, double z, double z2, int r0, int r1, int c0, int c1, int m,
                  double ball2) {
    if (r1 < r0 || c1 < c0) return;
    add_pair(u, w, z, z2, r0, c0, m, ball2);
    if (c1 > c0) add_pair(u, w, z, z2, r0, c1, m, ball2);
    if (r1 > r0) {
      add_pair(u, w, z, z2, r1, c0, m, ball2);
      if (c1 > c0) add_pair(u, w, z, z2, r1, c1, m, ball2);
    }
  }

  /// Every (neighbour, cell) pair within the ball, in neighbour order then row-major cell
  /// order, for the map of frame (x, y, nf) with cells of size 1 / inv_h on an m x m grid; then
  /// all their Gaussian weights in one vectorised exponential (util/fast_math.hpp: four lanes
  /// with AVX2, same bits without; Eigen's two-lane exp was a quarter of the maps' time).
  void collect(const Offsets& d, const Eigen::Vector3d& nf, const Eigen::Vector3d& x,
               const Eigen::Vector3d& y, double inv_h, int m, double ball) {
    const int span = std::min(m, int(2 * ball) + 1);  // cells a ball reaches along one axis
    const size_t n = d.x.size(), most = n * size_t(span * span);
    if (cell.size() < most) {
      cell.resize(most);
      dist2.resize(most);
      height.resize(most);
      weight.resize(most);
    }
    count = 0;
    const int half = m / 2;
    const double ball2 = ball * ball;
    // Heights and map coordinates, in cells, of all neighbours at once (vectorised).
    hz.resize(n);
    hu.resize(n);
    hw.resize(n);
    d.project(nf, inv_h, hz.data());
    d.project(x, inv_h, hu.data());
    d.project(y, inv_h, hw.data());
    // Those within the ball's reach of the tangent plane, listed without a branch (a third of
    // them are out: the branch mispredicted).
    near.resize(n);
    size_t nn = 0;
    for (size_t j = 0; j < n; ++j) {
      near[nn] = uint32_t(j);
      nn += size_t(!(hz[j] * hz[j] > ball2));
    }
    for (size_t t = 0; t < nn; ++t) {
      const size_t j = near[t];
      const double z = hz[j];
      const double z2 = z * z;
      const double u = hu[j] + half, w = hw[j] + half;
      const int r0 = std::max(0, ceil_int(u - ball));
      const int r1 = std::min(m - 1, floor_int(u + ball));
      const int c0 = std::max(0, ceil_int(w - ball));
      const int c1 = std::min(m - 1, floor_int(w + ball));
      if (span <= 2) {
        add_block2(u, w, z, z2, r0, r1, c0, c1, m, ball2);
        continue;
      }
      for (int rr = r0; rr <= r1; ++rr)
        for (int cc = c0; cc <= c1; ++cc) add_pair(u, w, z, z2, rr, cc, m, ball2);
    }
    for (size_t e = 0; e < count; ++e) weight[e] = dist2[e] * -0.5;
    detail::exp_nonpositive_batch(weight.data(), weight.data(), count);
  }
};

thread_local Contributions contributions;
thread_local std::vector<double> cell_sums;  // per thread: 2 m^2 sums (weights, heights)
thread_local Offsets offsets;

}  // namespace

HeightMaps height_maps(const Points& points, const IndexMatrix& knn, int k,
                       const CanonicalFrames& frames, const HeightMapOptions& options,
                       const RunContext& run, Eigen::Index first) {
  const Eigen::Index n = knn.rows();
  const int m = options.size;
  if (m < 1 || m % 2 == 0) throw InvalidOptions("height_maps: size must be odd and positive");
  if (!(options.ball > 0)) throw InvalidOptions("height_maps: ball must be > 0");
  if (first < 0 || first + n > points.rows() || frames.rotations.rows() != n ||
      frames.rotated.rows() != n)
    throw InvalidOptions("height_maps: points, neighbour table and frames differ in size");
  if (k < 2 || k > knn.cols())
    throw InvalidOptions("height_maps: k must be in [2, " + std::to_string(knn.cols()) + "]");
  const int f = int(frames.rotated.cols() / 3);
  const int half = m / 2, mm = m * m;
  HeightMaps out(n, f * mm);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("height maps", 0, 1);
  detail::parallel_for(n, run.threads, run.progress ? &progress : nullptr, [&](int64_t i) {
    if (!frames.rotations.row(i).allFinite()) {
      out.row(i).setConstant(std::numeric_limits<float>::quiet_NaN());
      return;
    }
    Eigen::Matrix3d r;
    for (int c = 0; c < 9; ++c) r(c / 3, c % 3) = frames.rotations(i, c);
    const Eigen::Vector3d pi = points.row(first + i).transpose();
    const Eigen::Vector3d e1 = r.row(0).transpose(), e2 = r.row(1).transpose();
    Offsets& d = offsets;
    d.resize(static_cast<size_t>(k));
    double rad2 = 0;
    for (int c = 0; c < k; ++c) {
      const Eigen::Vector3d v = points.row(knn(i, c)).transpose() - pi;
      d.x[size_t(c)] = v[0];
      d.y[size_t(c)] = v[1];
      d.z[size_t(c)] = v[2];
      rad2 = std::max(rad2, v.squaredNorm());
    }
    const double h = std::sqrt(rad2) / (half + options.ball);
    if (!(h > 0)) {
      out.row(i).setZero();
      return;
    }
    const double inv_h = 1.0 / h;
    cell_sums.resize(2 * size_t(mm));
    double* wsum = cell_sums.data();
    double* zsum = wsum + mm;
    for (int a = 0; a < f; ++a) {
      const Eigen::Vector3d nf = r.transpose() * frames.rotated.block<1, 3>(i, 3 * a).transpose();
      Eigen::Vector3d x = e1 - e1.dot(nf) * nf;
      if (x.norm() < 1e-6) x = e2 - e2.dot(nf) * nf;
      x.normalize();
      Eigen::Vector3d y = e2 - e2.dot(nf) * nf - e2.dot(x) * x;
      y = y.norm() > 1e-6 ? Eigen::Vector3d(y.normalized()) : Eigen::Vector3d(nf.cross(x));
      Contributions& ct = contributions;
      ct.collect(d, nf, x, y, inv_h, m, options.ball);
      std::fill(wsum, wsum + 2 * mm, 0.0);
      for (size_t e = 0; e < ct.count; ++e) {
        wsum[ct.cell[e]] += ct.weight[e];
        zsum[ct.cell[e]] += ct.weight[e] * ct.height[e];
      }
      for (int b = 0; b < mm; ++b)
        out(i, a * mm + b) = wsum[b] > 0 ? float(zsum[b] / wsum[b]) : 0.0f;
    }
  });
  return out;
}

}  // namespace nhnet
