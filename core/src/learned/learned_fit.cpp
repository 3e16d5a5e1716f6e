// Learned weighted jet fit of --method nhnet (learned/learned_fit.hpp; not the paper's): per
// point, member features in the frame of the mixed normal, a two-layer ReLU embedding per member,
// its max-pool, softplus weights per member and a sigmoid gate (blocks of points through one
// matrix product per layer), then a weighted degree-2 height fit. The weights are in
// learned_fit_weights.inc, written by tools/fit_learned_fit.py
// (docs/design/decisions.md#learned-weighted-jet-fit-issue-23); the arithmetic here is that tool's
// LearnedFit.forward, step for step.
#include "nhnet/learned/learned_fit.hpp"

#include "geometry/tangent_frame.hpp"
#include "learned/dense_rows.hpp"
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

static_assert(kH == detail::kDenseWidth && kG == detail::kDenseWidth,
              "the member network's layers are dense_rows layers of 16 outputs");

/// Member features, one row of kF a member.
using MemberFeatures = Eigen::Matrix<float, Eigen::Dynamic, kF, Eigen::RowMajor>;

/// The fitted layers, each weight transposed to dense_rows' layout (in x out; torch stores out
/// x in): columns [c0, c0 + in) of torch's `w` (out rows of `stride` floats).
template <int In>
std::array<float, In * kH> transposed(const float* w, int stride, int c0) {
  std::array<float, In * kH> t{};
  for (int o = 0; o < kH; ++o)
    for (int k = 0; k < In; ++k) t[size_t(k * kH + o)] = w[o * stride + c0 + k];
  return t;
}
struct Layers {
  std::array<float, kF* kH> w1 = transposed<kF>(&kW1[0][0], kF, 0);
  std::array<float, kH* kH> w2 = transposed<kH>(&kW2[0][0], kH, 0);
  std::array<float, kH* kH> w3_member = transposed<kH>(&kW3[0][0], 2 * kH, 0);
  std::array<float, kH* kH> w3_pooled = transposed<kH>(&kW3[0][0], 2 * kH, kH);
  std::array<float, (kH + 1)* kG> g1 = transposed<kH + 1>(&kG1[0][0], kH + 1, 0);
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
                  MemberFeatures& features, Eigen::Index row) {
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

/// One thread's buffers for member_weights (reused from block to block).
struct MemberScratch {
  std::vector<float> e1, e2, z;  // kBlock x kM rows of kH: the layers' outputs
  std::vector<float> gate_in;    // kBlock rows of kH + 1: the members' max-pool, the noise
  std::vector<float> global, hidden;
  std::vector<double> score;  // each member's score, then its weight (softplus)
};

/// The network on a block's member features (len x kM rows): each member's weight (`weights`,
/// same rows) and each point's gate (`gates`, len). Each layer through dense_rows.
void member_weights(const Layers& l, const MemberFeatures& features, Eigen::Index len, float noise,
                    Eigen::VectorXf& weights, Eigen::VectorXf& gates) {
  thread_local MemberScratch m;
  const size_t rows = size_t(len) * kM, n = size_t(len);
  m.e1.resize(rows * kH);
  m.e2.resize(rows * kH);
  m.z.resize(rows * kH);
  m.gate_in.resize(n * (kH + 1));
  m.global.resize(n * kH);
  m.hidden.resize(n * kG);
  detail::dense_rows(features.data(), kF, rows, kF, l.w1.data(), kB1.data(), rows, true,
                     m.e1.data());
  detail::dense_rows(m.e1.data(), kH, rows, kH, l.w2.data(), kB2.data(), rows, true, m.e2.data());
  for (size_t r = 0; r < n; ++r) {  // max over each point's members, then the noise: gate_in
    float* p = &m.gate_in[r * (kH + 1)];
    std::copy_n(&m.e2[r * kM * kH], kH, p);
    for (size_t j = 1; j < size_t(kM); ++j)
      for (int c = 0; c < kH; ++c) p[c] = std::max(p[c], m.e2[(r * kM + j) * kH + size_t(c)]);
    p[kH] = noise;
  }
  // The pooled layer reads the max-pool part of gate_in's rows.
  detail::dense_rows(m.gate_in.data(), kH + 1, n, kH, l.w3_pooled.data(), kB3.data(), n, false,
                     m.global.data());
  // Each member with its point's pooled term as the bias.
  detail::dense_rows(m.e2.data(), kH, rows, kH, l.w3_member.data(), m.global.data(), kM, true,
                     m.z.data());
  m.score.resize(rows);
  for (size_t j = 0; j < rows; ++j) {
    float wsum = 0;
    for (int c = 0; c < kH; ++c) wsum += m.z[j * kH + size_t(c)] * kW4[size_t(c)];
    m.score[j] = double(wsum + kB4);
  }
  detail::softplus_batch(m.score.data(), m.score.data(), rows);
  weights.resize(Eigen::Index(rows));
  for (size_t j = 0; j < rows; ++j) weights[Eigen::Index(j)] = float(m.score[j]);
  detail::dense_rows(m.gate_in.data(), kH + 1, n, kH + 1, l.g1.data(), kGB1.data(), n, true,
                     m.hidden.data());
  gates.resize(len);
  for (size_t r = 0; r < n; ++r) {
    float g = 0;
    for (int c = 0; c < kG; ++c) g += m.hidden[r * kG + size_t(c)] * kG2[size_t(c)];
    gates[Eigen::Index(r)] = 1 / (1 + std::exp(-(g + kGB2)));
  }
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
  MemberFeatures features = MemberFeatures::Zero(len * kM, kF);
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
