// Learned weighted jet fit of --method nhnet (learned/learned_fit.hpp; not the paper's): per
// point, member features in the frame of the mixed normal, a two-layer ReLU embedding per member,
// its max-pool, softplus weights per member and a sigmoid gate (blocks of points through one
// matrix product per layer), then a weighted degree-2 height fit. The weights are in
// learned_fit_weights.inc, written by tools/fit_learned_fit.py
// (docs/design/decisions.md#learned-weighted-jet-fit-issue-23); the arithmetic here is that tool's
// LearnedFit.forward, step for step.
#include "nhnet/learned/learned_fit.hpp"

#include "geometry/tangent_frame.hpp"
#include "nhnet/errors.hpp"
#include "util/parallel.hpp"
#include "util/spatial_order.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace nhnet {

namespace {

#ifdef NHNET_LEARNED_FIT_WEIGHTS  // core/CMakeLists.txt's NHNET_LEARNED_FIT_WEIGHTS
#include NHNET_LEARNED_FIT_WEIGHTS
#else
#include "learned/learned_fit_weights.inc"
#endif

constexpr int kM = kFitMembers, kH = kFitHidden, kF = kFitFeatures, kG = kFitGateHidden;
/// Points whose members go through the network together: one matrix product per layer for
/// kBlock x kM members instead of a small one per point.
constexpr int kBlock = 128;

template <int R, int C>
using Fixed = Eigen::Matrix<float, R, C, Eigen::RowMajor>;
using Hidden = Eigen::Matrix<float, 1, kH>;

/// The fitted layers as matrices (out x in, as torch stores them) and row vectors.
struct Layers {
  Eigen::Map<const Fixed<kH, kF>> w1{&kW1[0][0]};
  Eigen::Map<const Fixed<kH, kH>> w2{&kW2[0][0]};
  Eigen::Map<const Fixed<kH, 2 * kH>> w3{&kW3[0][0]};
  Eigen::Map<const Fixed<kG, kH + 1>> g1{&kG1[0][0]};
  Eigen::Map<const Hidden> b1{kB1.data()}, b2{kB2.data()}, b3{kB3.data()}, w4{kW4.data()};
  Eigen::Map<const Eigen::Matrix<float, 1, kG>> gb1{kGB1.data()}, g2{kG2.data()};
};

/// A point's members in its normal's frame: scaled tangent coordinates and heights (u, v, h)
/// and tangent axes, as LearnedFit.forward.
struct Frame {
  Eigen::Vector3d n, a, b;  ///< the point's normal (the frame's third axis) and tangent axes
  Eigen::Matrix<double, kM, 1> u, v, h;
};

/// Frame of point i, whose normal is fr.n, and its members' features (kM rows of `features`
/// from `row`); false when its members all sit on it (no radius). `noise`: log of the cloud's
/// noise ratio.
bool member_frame(const LearnedFitInput& in, Eigen::Index i, float noise, Frame& fr,
                  Eigen::MatrixXf& features, Eigen::Index row) {
  const Points& pts = *in.points;
  const Eigen::Vector3d p = pts.row(i).transpose(), n = fr.n;
  std::array<Eigen::Index, kM> member;
  std::array<Eigen::Vector3d, kM> q;
  double radius = 0;
  for (int j = 0; j < kM; ++j) {
    member[size_t(j)] = Eigen::Index((*in.members)(i, j));
    q[size_t(j)] = pts.row(member[size_t(j)]).transpose() - p;
    radius = std::max(radius, q[size_t(j)].norm());
  }
  if (!(radius > 0)) return false;
  detail::tangent_axes(n, fr.a, fr.b);
  for (int j = 0; j < kM; ++j) {
    const Eigen::Vector3d qj = q[size_t(j)] / radius;
    fr.u[j] = qj.dot(fr.a);
    fr.v[j] = qj.dot(fr.b);
    fr.h[j] = qj.dot(n);
  }
  const double mean_h = fr.h.mean();
  for (int j = 0; j < kM; ++j) {
    const auto nj = in.normals->row(member[size_t(j)]);
    const double c = nj.allFinite() ? std::abs(nj.dot(n.transpose())) : 0.0;
    const double f[kF - 1] = {std::sqrt(fr.u[j] * fr.u[j] + fr.v[j] * fr.v[j]),  // the tool's
                              10 * std::abs(fr.h[j] - mean_h),
                              10 * std::abs(fr.h[j]),
                              1 - c,
                              c,
                              double(j) / (kM - 1)};
    for (int k = 0; k < kF - 1; ++k) features(row + j, k) = float(f[k]);
    features(row + j, kF - 1) = noise;
  }
  return true;
}

float softplus(float x) { return x > 20 ? x : std::log1p(std::exp(x)); }

/// The network on a block's member features (len x kM rows): each member's weight (`weights`,
/// same rows) and each point's gate (`gates`, len).
void member_weights(const Layers& l, const Eigen::MatrixXf& features, Eigen::Index len, float noise,
                    Eigen::VectorXf& weights, Eigen::VectorXf& gates) {
  Eigen::MatrixXf e = features * l.w1.transpose();
  e = (e.rowwise() + l.b1).cwiseMax(0.0f);
  Eigen::MatrixXf e2 = e * l.w2.transpose();
  e2 = (e2.rowwise() + l.b2).cwiseMax(0.0f);
  Eigen::MatrixXf pooled(len, kH);
  for (Eigen::Index r = 0; r < len; ++r)
    pooled.row(r) = e2.middleRows(r * kM, kM).colwise().maxCoeff();
  Eigen::MatrixXf global = pooled * l.w3.rightCols<kH>().transpose();
  global.rowwise() += l.b3;
  Eigen::MatrixXf z = e2 * l.w3.leftCols<kH>().transpose();
  for (Eigen::Index r = 0; r < len; ++r) z.middleRows(r * kM, kM).rowwise() += global.row(r);
  z = z.cwiseMax(0.0f);
  weights = z.lazyProduct(l.w4.transpose());
  for (Eigen::Index j = 0; j < weights.size(); ++j) weights[j] = softplus(weights[j] + kB4);
  Eigen::MatrixXf gate_in(len, kH + 1);
  gate_in << pooled, Eigen::VectorXf::Constant(len, noise);
  Eigen::MatrixXf hidden = gate_in * l.g1.transpose();
  hidden = (hidden.rowwise() + l.gb1).cwiseMax(0.0f);
  gates = hidden.lazyProduct(l.g2.transpose());
  for (Eigen::Index r = 0; r < len; ++r) gates[r] = 1 / (1 + std::exp(-(gates[r] + kGB2)));
}

/// The weighted jet's normal in frame fr (fr.n - c1 a - c2 b), or NaN when the system is singular.
Eigen::Vector3d weighted_jet(const Frame& fr, const float* w) {
  detail::JetSystem sys;
  double total = 0;
  for (int j = 0; j < kM; ++j) {
    sys.add(fr.u[j], fr.v[j], fr.h[j], double(w[j]));
    total += double(w[j]);
  }
  if (!(total > 0)) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Matrix<double, 6, 6> ata = sys.ata();
  ata.diagonal().array() += kFitRidge * total;
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(ata);
  const Eigen::Matrix<double, 6, 1> c = ldlt.solve(sys.atb);
  if (ldlt.info() != Eigen::Success || !c.allFinite())
    return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  return (fr.n - c[1] * fr.a - c[2] * fr.b).normalized();
}

/// Refits the points rows[0, len) into `out`; a point whose fit is degenerate keeps its normal.
void fit_block(const LearnedFitInput& in, const Layers& l, const int64_t* rows, Eigen::Index len,
               float noise, Normals& out) {
  std::vector<Frame> frames(static_cast<size_t>(len));
  std::vector<uint8_t> ok(size_t(len), 0);
  Eigen::MatrixXf features = Eigen::MatrixXf::Zero(len * kM, kF);
  for (Eigen::Index r = 0; r < len; ++r) {
    Frame& fr = frames[size_t(r)];
    fr.n = in.normals->row(rows[r]).transpose();
    ok[size_t(r)] = fr.n.allFinite() && member_frame(in, rows[r], noise, fr, features, r * kM);
  }
  Eigen::VectorXf weights, gates;
  member_weights(l, features, len, noise, weights, gates);
  for (Eigen::Index r = 0; r < len; ++r) {
    const Eigen::Vector3d& n = frames[size_t(r)].n;
    out.row(rows[r]) = n.transpose();
    if (!ok[size_t(r)]) continue;
    const Eigen::Vector3d fitted = weighted_jet(frames[size_t(r)], &weights[r * kM]);
    if (!fitted.allFinite()) continue;
    const Eigen::Vector3d mixed = n + double(gates[r]) * (fitted - n);
    if (mixed.norm() > 1e-12) out.row(rows[r]) = mixed.normalized().transpose();
  }
}

}  // namespace

Normals learned_fit(const LearnedFitInput& in, const RunContext& run) {
  if (!in.points || !in.normals || !in.members)
    throw InvalidOptions("learned fit: an input is missing");
  const Eigen::Index m = in.normals->rows();
  if (in.points->rows() != m || in.members->rows() != m || in.members->cols() != kFitMembers)
    throw InvalidOptions("learned fit: inputs differ in size or the member table does not have " +
                         std::to_string(kFitMembers) + " columns");
  const Layers layers;
  Normals out(m, 3);
  detail::Progress progress(run.progress);
  if (run.progress) progress.stage("learned fit", 0, 1);
  // Blocks of points near each other (util/spatial_order.hpp): their members share cache lines.
  const std::vector<int64_t> order = detail::spatial_order(*in.points);
  const float noise = float(std::log(std::max(in.noise_ratio, 1e-4)));
  const int64_t blocks = (m + kBlock - 1) / kBlock;
  detail::parallel_for(blocks, run.threads, run.progress ? &progress : nullptr, [&](int64_t c) {
    const Eigen::Index len = std::min<Eigen::Index>(kBlock, m - c * kBlock);
    fit_block(in, layers, order.data() + c * kBlock, len, noise, out);
  });
  return out;
}

}  // namespace nhnet
