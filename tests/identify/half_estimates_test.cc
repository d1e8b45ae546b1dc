// EG of two halves by one Newton step from the whole window's estimate (half_estimates.h): on a
// least-squares problem that is linear in theta (every chunk's residual A_c (theta - theta_c)),
// the step lands exactly on each half's own optimum, with and without a prior, so the EG there
// is the EG of the half fitted alone; the published sigma is widened only when the halves
// disagree by more than kHalvesCoverZ combined sigma.
#include "half_estimates.h"

#include <gtest/gtest.h>

#include <random>

#include "ndsid/model/single_track.h"

namespace ndsid::identify {
namespace {

constexpr int kNp = 6;
const std::vector<double> kScale = {1900, 2700, 75000, 120000, 1.15, 14.8};
constexpr double kWheelbase = 2.648;

struct Problem {
  std::vector<Eigen::MatrixXd> a;        // per chunk
  std::vector<Eigen::VectorXd> target;   // per chunk: where its residual vanishes
  std::vector<int> half;                 // 0 or 1
};

Problem Make(uint64_t seed, int chunks, double half_offset) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0, 1);
  Problem p;
  for (int c = 0; c < chunks; ++c) {
    Eigen::MatrixXd a(20, kNp);
    for (int i = 0; i < a.rows(); ++i)
      for (int j = 0; j < kNp; ++j) a(i, j) = n(rng);
    a.col(0).setZero();  // m is fixed: no information
    Eigen::VectorXd t = Eigen::VectorXd::Ones(kNp);
    for (int j = 1; j < kNp; ++j) t[j] += 0.02 * n(rng) + (c % 2 ? half_offset : 0.0);
    p.a.push_back(a);
    p.target.push_back(t);
    p.half.push_back(c % 2);
  }
  return p;
}

// The exact minimiser of sum over `which` chunks (and the prior) restricted to the free block.
Eigen::VectorXd Solve(const Problem& p, int which, const Eigen::MatrixXd& prior, double level, const Eigen::VectorXd& prior_at) {
  Eigen::MatrixXd h = level * prior;
  Eigen::VectorXd rhs = level * prior * prior_at;
  for (size_t c = 0; c < p.a.size(); ++c) {
    if (which >= 0 && p.half[c] != which) continue;
    h += p.a[c].transpose() * p.a[c];
    rhs += p.a[c].transpose() * p.a[c] * p.target[c];
  }
  Eigen::VectorXd x = Eigen::VectorXd::Ones(kNp);
  const Eigen::MatrixXd hf = h.bottomRightCorner(kNp - 1, kNp - 1);
  const Eigen::VectorXd rf = rhs.tail(kNp - 1) - h.bottomLeftCorner(kNp - 1, 1) * x[0];
  x.tail(kNp - 1) = hf.ldlt().solve(rf);
  return x;
}

double EgAt(const Eigen::VectorXd& theta) {
  double base[kNp];
  for (int i = 0; i < kNp; ++i) base[i] = theta[i] * kScale[static_cast<size_t>(i)];
  return model::SelfSteerGradient(model::Params<double>::FromArray(base), kWheelbase);
}

void Check(double prior_sd, uint64_t seed) {
  const Problem p = Make(seed, 40, 0.01);
  Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(kNp, kNp);
  Eigen::VectorXd prior_at = Eigen::VectorXd::Ones(kNp);
  if (prior_sd > 0) prior(5, 5) = 1.0 / (prior_sd * prior_sd);  // a prior on is
  const double level = 0.7;
  const Eigen::VectorXd all = Solve(p, -1, prior, level, prior_at);
  HalfMoments m[2];
  for (HalfMoments& x : m) x.Init(kNp);
  for (size_t c = 0; c < p.a.size(); ++c) {
    const Eigen::VectorXd e = p.a[c] * (all - p.target[c]);
    m[p.half[c]].AddChunk(p.a[c].transpose() * p.a[c], p.a[c].transpose() * e);
  }
  m[0].drives = m[1].drives = 20;
  HalvesContext ctx;
  ctx.theta.assign(all.data(), all.data() + kNp);
  ctx.scale = kScale;
  ctx.free = {1, 2, 3, 4, 5};
  ctx.prior_info = prior;
  ctx.noise_level = level;
  ctx.wheelbase_m = kWheelbase;
  const auto [a, b] = EstimateHalves(m[0], m[1], ctx);
  ASSERT_TRUE(a.valid && b.valid) << a.reason << b.reason;
  EXPECT_NEAR(a.eg_rad_per_mps2, EgAt(Solve(p, 0, prior, level, prior_at)), 1e-12) << seed;
  EXPECT_NEAR(b.eg_rad_per_mps2, EgAt(Solve(p, 1, prior, level, prior_at)), 1e-12) << seed;
  EXPECT_GT(a.eg_se_rad_per_mps2, 0);
  EXPECT_EQ(a.chunks, 20u);
}

TEST(HalfEstimates, OneNewtonStepIsEachHalfsOwnOptimum) {
  for (uint64_t seed : {1, 2, 3}) Check(0, seed);
}

TEST(HalfEstimates, PriorsAreKeptByEachHalf) {
  for (uint64_t seed : {4, 5}) Check(0.01, seed);
}

TEST(HalfEstimates, AHalfWithoutChunksIsNotValid) {
  HalfMoments a, b;
  a.Init(kNp);
  b.Init(kNp);
  b.AddChunk(Eigen::MatrixXd::Identity(kNp, kNp), Eigen::VectorXd::Zero(kNp));
  HalvesContext ctx{std::vector<double>(kNp, 1.0), kScale, {1, 2, 3, 4, 5}, Eigen::MatrixXd::Zero(kNp, kNp), 1.0, kWheelbase};
  const auto [x, y] = EstimateHalves(a, b, ctx);
  EXPECT_FALSE(x.valid);
  EXPECT_EQ(x.reason, "no chunk in this half");
}

TEST(HalfEstimates, SigmaWidensOnlyBeyondTheCover) {
  HalfEstimate a{.valid = true, .reason = "", .eg_rad_per_mps2 = 0.0070, .eg_se_rad_per_mps2 = 1e-4, .drives = 3, .chunks = 30};
  HalfEstimate b = a;
  b.eg_rad_per_mps2 = 0.0070 + 1.5 * std::sqrt(2.0) * 1e-4;  // 1.5 combined sigma: within the cover
  EXPECT_DOUBLE_EQ(HonestSigma(7e-5, a, b), 7e-5);
  b.eg_rad_per_mps2 = 0.0070 + 5 * std::sqrt(2.0) * 1e-4;  // 5 combined sigma: sigma x 2.5
  EXPECT_NEAR(HonestSigma(7e-5, a, b), 7e-5 * 2.5, 1e-12);
  b.valid = false;
  EXPECT_DOUBLE_EQ(HonestSigma(7e-5, a, b), 7e-5);
}

}  // namespace
}  // namespace ndsid::identify
