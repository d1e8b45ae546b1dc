// RegressionStats: the sufficient statistics behind the steady-state estimate. Checked against
// a direct least-squares solve (Eigen QR on the samples themselves), never against stored numbers.
#include "ndsid/stats/regression_stats.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <functional>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "ndsid/common/error.h"

namespace ndsid::stats {
namespace {

struct Data {
  std::vector<std::array<double, 3>> x;
  std::vector<double> y;
};

// y = 2 x0 - x1 + 0.5 + noise, x2 = 1 (intercept); `scale` multiplies every regressor and y.
Data MakeData(int n, uint64_t seed, double scale = 1.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  Data d;
  for (int i = 0; i < n; ++i) {
    const std::array<double, 3> x{scale * g(rng), scale * g(rng), scale};
    d.x.push_back(x);
    d.y.push_back(2 * x[0] - x[1] + 0.5 * x[2] + 0.1 * scale * g(rng));
  }
  return d;
}

RegressionStats Feed(const Data& d, size_t from, size_t to) {
  RegressionStats r;
  for (size_t i = from; i < to; ++i) r.Add(d.x[i], d.y[i]);
  return r;
}

// Sum of |terms| of every statistic: feeding |x|, |y| gives sum |x_i x_j|, sum |x_i y|, ...
RegressionStats AbsStats(const Data& d) {
  RegressionStats r;
  for (size_t i = 0; i < d.y.size(); ++i) r.Add({std::abs(d.x[i][0]), std::abs(d.x[i][1]), std::abs(d.x[i][2])}, std::abs(d.y[i]));
  return r;
}

// Sums of the same n terms in another order differ by at most gamma_n * sum|terms|
// (gamma_n = n eps / (1 - n eps), Higham, "Accuracy and Stability", eq. 4.4); the tolerance.
void ExpectSameStats(const RegressionStats& a, const RegressionStats& b, const RegressionStats& abs_terms) {
  const double n = abs_terms.n();
  const double gamma = 2 * n * std::numeric_limits<double>::epsilon();  // two sums reordered
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(a.xtx()[i], b.xtx()[i], gamma * abs_terms.xtx()[i]) << "xtx " << i;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a.xty()[i], b.xty()[i], gamma * abs_terms.xty()[i]) << "xty " << i;
  EXPECT_NEAR(a.yty(), b.yty(), gamma * abs_terms.yty());
  EXPECT_EQ(a.n(), b.n());  // integer counts below 2^53: exact
}

struct Reference {
  Eigen::Vector3d theta;
  double sigma;
  Eigen::Matrix3d covariance;
};

// Least squares directly on the samples (QR of X, not the normal equations).
Reference EigenSolve(const Data& d) {
  const int n = static_cast<int>(d.y.size());
  Eigen::MatrixXd x(n, 3);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 3; ++j) x(i, j) = d.x[i][j];
    y(i) = d.y[i];
  }
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(x);
  Reference r;
  r.theta = qr.solve(y);
  r.sigma = (y - x * r.theta).norm() / std::sqrt(n - 3.0);
  const Eigen::Matrix3d rr = qr.matrixQR().topRows(3).triangularView<Eigen::Upper>();
  const Eigen::Matrix3d rinv = rr.inverse();
  r.covariance = r.sigma * r.sigma * rinv * rinv.transpose();
  return r;
}

void ExpectMatchesReference(const LsSolution& s, const Reference& ref, double rel) {
  ASSERT_TRUE(s.valid) << s.reason;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(s.theta[i], ref.theta(i), rel * std::abs(ref.theta(i))) << "theta " << i;
  EXPECT_NEAR(s.sigma, ref.sigma, rel * ref.sigma);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      const double scale = std::sqrt(ref.covariance(i, i) * ref.covariance(j, j));
      EXPECT_NEAR(s.covariance[i * 3 + j], ref.covariance(i, j), rel * scale) << "cov " << i << j;
    }
  }
}

bool BitwiseEqual(const RegressionStats& a, const RegressionStats& b) {
  auto same = [](double u, double v) { return std::memcmp(&u, &v, sizeof u) == 0; };
  bool ok = same(a.yty(), b.yty()) && same(a.n(), b.n());
  for (int i = 0; i < 9; ++i) ok = ok && same(a.xtx()[i], b.xtx()[i]);
  for (int i = 0; i < 3; ++i) ok = ok && same(a.xty()[i], b.xty()[i]);
  return ok;
}

// Catches: statistics that are not additive (the daemon merges a drive's pending statistics
// into the learned ones), or a merge that drops or double-counts a term.
TEST(RegressionStats, DisjointHalvesMergedEqualOneFedAllSamples) {
  const Data d = MakeData(1000, 11);
  const RegressionStats whole = Feed(d, 0, 1000);
  for (size_t cut : {size_t{0}, size_t{1}, size_t{400}, size_t{999}, size_t{1000}}) {
    RegressionStats a = Feed(d, 0, cut);
    a.Merge(Feed(d, cut, 1000));
    ExpectSameStats(a, whole, AbsStats(d));
  }
}

// Catches: a merge that depends on the order in which the daemon combines partial statistics.
TEST(RegressionStats, MergeIsCommutativeAndAssociative) {
  const Data d = MakeData(900, 12);
  const RegressionStats a = Feed(d, 0, 300), b = Feed(d, 300, 600), c = Feed(d, 600, 900);
  RegressionStats ab = a, ba = b;
  ab.Merge(b);
  ba.Merge(a);
  EXPECT_TRUE(BitwiseEqual(ab, ba));  // IEEE addition is commutative: exact
  RegressionStats ab_c = ab, bc = b;
  ab_c.Merge(c);
  bc.Merge(c);
  RegressionStats a_bc = a;
  a_bc.Merge(bc);
  ExpectSameStats(ab_c, a_bc, AbsStats(d));
}

// Catches: an empty statistics object that is not the neutral element (e.g. a non-zero default).
TEST(RegressionStats, MergingAnEmptyOneChangesNothing) {
  const Data d = MakeData(50, 13);
  const RegressionStats a = Feed(d, 0, 50);
  RegressionStats left = a, right;
  left.Merge(RegressionStats{});
  right.Merge(a);
  EXPECT_TRUE(BitwiseEqual(left, a));
  EXPECT_TRUE(BitwiseEqual(right, a));
}

// Catches: a solve that disagrees with ordinary least squares on the same samples (theta, the
// residual sigma with n - 3 degrees of freedom, and the covariance sigma^2 (X'X)^-1).
TEST(RegressionStats, SolveMatchesDirectLeastSquares) {
  const Data d = MakeData(500, 14);
  ExpectMatchesReference(Feed(d, 0, 500).Solve(), EigenSolve(d), 1e-9);
}

// Catches: exponential forgetting that is not "old data weigh factor^age": forgetting by f then
// adding new samples must equal adding the old samples with weight f.
TEST(RegressionStats, ForgettingWeighsOldSamplesByTheFactor) {
  const Data d = MakeData(600, 15);
  const double f = 0.7;
  RegressionStats forgot = Feed(d, 0, 300);
  forgot.Forget(f);
  for (size_t i = 300; i < 600; ++i) forgot.Add(d.x[i], d.y[i]);
  RegressionStats weighted;
  for (size_t i = 0; i < 600; ++i) weighted.Add(d.x[i], d.y[i], i < 300 ? f : 1.0);
  const RegressionStats abs_terms = AbsStats(d);
  const double gamma = 4 * 600 * std::numeric_limits<double>::epsilon();
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(forgot.xtx()[i], weighted.xtx()[i], gamma * abs_terms.xtx()[i]);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(forgot.xty()[i], weighted.xty()[i], gamma * abs_terms.xty()[i]);
  EXPECT_NEAR(forgot.yty(), weighted.yty(), gamma * abs_terms.yty());
  EXPECT_NEAR(forgot.n(), 0.7 * 300 + 300, gamma * 600);
  // Forgetting everything uniformly leaves the estimate unchanged.
  RegressionStats all = Feed(d, 0, 600), scaled = all;
  scaled.Forget(0.5);
  const LsSolution s0 = all.Solve(), s1 = scaled.Solve();
  ASSERT_TRUE(s0.valid && s1.valid);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(s1.theta[i], s0.theta[i], 1e-12 * std::abs(s0.theta[i]));
  RegressionStats one = all;
  one.Forget(1.0);
  EXPECT_TRUE(BitwiseEqual(one, all));
}

RegressionStats ThroughStateFile(const RegressionStats& r) {
  return RegressionStats::FromJson(JsonIn(ParseCbor(ToCbor(r.ToJson()), "test"), "stats"));
}

// Catches: an encoding that rounds or loses the sign of zero, subnormals or extreme exponents:
// the daemon's learned state must survive a restart bit for bit (through CBOR, as the state file
// holds it, and through text JSON).
TEST(RegressionStats, RoundTripIsBitwiseExact) {
  std::vector<RegressionStats> cases;
  cases.emplace_back();                       // empty
  cases.push_back(Feed(MakeData(1, 16), 0, 1));  // one sample
  const Data big = MakeData(20000, 17);
  cases.push_back(Feed(big, 0, big.y.size()));   // large
  RegressionStats extreme;
  extreme.Add({1e-160, -1e150, 4.9e-324}, -0.0, 1.0 / 3.0);  // tiny, huge, subnormal, -0
  cases.push_back(extreme);
  for (const RegressionStats& r : cases) {
    const RegressionStats back = ThroughStateFile(r);
    EXPECT_TRUE(BitwiseEqual(back, r)) << r.ToJson().dump() << "\n" << back.ToJson().dump();
    const RegressionStats text = RegressionStats::FromJson(JsonIn(nlohmann::json::parse(r.ToJson().dump()), "stats"));
    EXPECT_TRUE(BitwiseEqual(text, r)) << r.ToJson().dump();
  }
}

// Catches: a malformed document accepted as a silently different state (a restored daemon
// would resume from wrong statistics) or a crash on it; the message names the bad field.
TEST(RegressionStats, MalformedDocumentIsRejectedWithTheOffendingField) {
  const RegressionStats r = Feed(MakeData(20, 18), 0, 20);
  const nlohmann::json good = r.ToJson();
  auto rejected = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& path) {
    nlohmann::json j = good;
    edit(j);
    try {
      RegressionStats::FromJson(JsonIn(j, "stats"));
      ADD_FAILURE() << "accepted " << j.dump();
    } catch (const CodecError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ":", 0), 0u) << e.what();
    }
  };
  rejected([](nlohmann::json& j) { j["xtx"].erase(8); }, "stats.xtx");
  rejected([](nlohmann::json& j) { j["xtx"].push_back(1.0); }, "stats.xtx");
  rejected([](nlohmann::json& j) { j["xty"] = 3; }, "stats.xty");
  rejected([](nlohmann::json& j) { j["xtx"][4] = "oops"; }, "stats.xtx[4]");
  rejected([](nlohmann::json& j) { j["xty"][1] = nullptr; }, "stats.xty[1]");  // text JSON's NaN
  rejected([](nlohmann::json& j) { j["yty"] = std::numeric_limits<double>::infinity(); }, "stats.yty");
  rejected([](nlohmann::json& j) { j["n"] = -1.0; }, "stats.n");
  rejected([](nlohmann::json& j) { j.erase("n"); }, "stats.n");
  EXPECT_THROW(ThroughStateFile(r).FromJson(JsonIn(nlohmann::json::array(), "stats")), CodecError);
}

// Catches: a non-finite sample poisoning the statistics for ever (every later Solve() and the
// persisted state would carry the NaN). The documented rule: such a sample is ignored.
TEST(RegressionStats, NonFiniteSamplesAreIgnored) {
  const Data d = MakeData(100, 19);
  RegressionStats r = Feed(d, 0, 100);
  const RegressionStats before = r;
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  r.Add({nan, 1, 1}, 1);
  r.Add({1, inf, 1}, 1);
  r.Add({1, 1, 1}, -inf);
  r.Add({1, 1, 1}, 1, nan);
  EXPECT_TRUE(BitwiseEqual(r, before));
  EXPECT_NO_THROW(ThroughStateFile(r));
}

// Catches: a solve that is only right near unit magnitudes (the cofactor inverse is scaled to
// unit diagonal; products of 1e150-sized sums overflow without it).
TEST(RegressionStats, HugeAndTinyMagnitudesSolveLikeUnitOnes) {
  for (double scale : {1e-100, 1e-10, 1e10, 1e100}) {
    const Data d = MakeData(300, 20, scale);
    ExpectMatchesReference(Feed(d, 0, 300).Solve(), EigenSolve(d), 1e-8);
  }
}

// Catches: garbage coefficients from a singular or rank-deficient X'X instead of "not determined".
TEST(RegressionStats, CollinearOrTooFewSamplesAreNotDetermined) {
  const Data d = MakeData(100, 21);
  RegressionStats collinear, zero_column, single, empty;
  for (size_t i = 0; i < d.y.size(); ++i) {
    collinear.Add({d.x[i][0], 3 * d.x[i][0], 1}, d.y[i]);  // x1 = 3 x0
    zero_column.Add({d.x[i][0], 0, 1}, d.y[i]);
  }
  single.Add(d.x[0], d.y[0]);
  for (const RegressionStats* r : {&collinear, &zero_column, &single, &empty}) {
    const LsSolution s = r->Solve();
    EXPECT_FALSE(s.valid);
    EXPECT_FALSE(s.reason.empty());
    for (double t : s.theta) EXPECT_EQ(t, 0.0);
  }
}

}  // namespace
}  // namespace ndsid::stats
