#include <gtest/gtest.h>

#include <random>

#include "ndsid/model/single_track.h"
#include "ndsid/stats/coverage.h"
#include "ndsid/stats/regression_stats.h"
#include "ndsid/stats/steady_state.h"

namespace ndsid::stats {
namespace {

gate::GatedSample SteadySample(double v, double ay, double steer, double r, bool yaw) {
  gate::GatedSample g;
  g.verdict = gate::Verdict::kAccepted;
  g.quasi_steady = true;
  g.segment_start = true;  // a stretch of its own: one observation per sample
  g.sample.speed_mps = v;
  g.sample.lat_accel_mps2 = ay;
  g.sample.steer_rad = steer;
  g.sample.yaw_rate_radps = r;
  g.sample.has_yaw_rate = yaw;
  g.sample.valid = true;
  return g;
}

// Catches: statistics that are not exactly additive (the daemon merges halves, days, vehicles).
TEST(RegressionStats, TwoHalvesMergedEqualTheWhole) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0, 1);
  RegressionStats whole, a, b;
  for (int i = 0; i < 1000; ++i) {
    const std::array<double, 3> x{n(rng), n(rng), 1.0};
    const double y = 2 * x[0] - x[1] + 0.5 + 0.1 * n(rng);
    whole.Add(x, y);
    (i < 400 ? a : b).Add(x, y);
  }
  a.Merge(b);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(a.xtx()[i], whole.xtx()[i], 1e-9 * std::abs(whole.xtx()[i]) + 1e-12);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(a.xty()[i], whole.xty()[i], 1e-9 * std::abs(whole.xty()[i]) + 1e-12);
  EXPECT_NEAR(a.yty(), whole.yty(), 1e-9 * whole.yty());
  EXPECT_EQ(a.n(), whole.n());
  const LsSolution s = whole.Solve();
  ASSERT_TRUE(s.valid);
  EXPECT_NEAR(s.theta[0], 2.0, 0.02);
  EXPECT_NEAR(s.theta[1], -1.0, 0.02);
  EXPECT_NEAR(s.theta[2], 0.5, 0.02);
  EXPECT_NEAR(s.sigma, 0.1, 0.01);
  const RegressionStats back = RegressionStats::FromJson(JsonIn(ParseCbor(ToCbor(whole.ToJson()), "t"), "stats"));
  EXPECT_EQ(back, whole);
}

TEST(RegressionStats, ForgettingScalesEverything) {
  RegressionStats s;
  s.Add({1, 2, 1}, 3);
  s.Forget(0.5);
  EXPECT_DOUBLE_EQ(s.n(), 0.5);
  EXPECT_DOUBLE_EQ(s.yty(), 4.5);
}

// Catches: the steady-state regression mis-assembled (EG from the Ackermann + EG*a_y relation).
TEST(SteadyStateStats, RecoversEgAndSteerRatioFromSteadyCornering) {
  const model::Params<double> p{1900, 2700, 75000, 120000, 1.15, 14.8};
  const double l = 2.648, eg = model::SelfSteerGradient(p, l);
  SteadyStateStats st;
  for (double v = 6; v < 35; v += 1.0) {
    for (double ay = -3.5; ay <= 3.5; ay += 0.25) {
      const double r = ay / v;
      const double steer = p.is * (l * r / v + eg * ay) + 0.01;  // + 0.01 rad offset
      st.Add(SteadySample(v, ay, steer, r, true));
    }
  }
  for (bool yaw : {false, true}) {
    const SteadyStateEstimate e = st.Estimate(l, yaw);
    ASSERT_TRUE(e.valid) << e.reason;
    EXPECT_NEAR(e.eg_rad_per_mps2, eg, 1e-9);
    EXPECT_NEAR(e.steer_ratio, 14.8, 1e-9);
    EXPECT_NEAR(e.steer_offset_rad, 0.01, 1e-9);
  }
  const SteadyStateStats back = SteadyStateStats::FromJson(JsonIn(ParseCbor(ToCbor(st.ToJson()), "t"), "steady"));
  EXPECT_EQ(back, st);
}

TEST(SteadyStateStats, TooFewSamplesIsNotValidWithReason) {
  SteadyStateStats st;
  st.Add(SteadySample(10, 1, 0.1, 0.1, false));
  const auto e = st.Estimate(2.6, false);
  EXPECT_FALSE(e.valid);
  EXPECT_FALSE(e.reason.empty());
}

// Catches: a KL divergence that does not vanish for identical distributions or grows wrongly.
TEST(Coverage, KlIsZeroForSameShapeAndPositiveForNewRegions) {
  Coverage a, b;
  for (int i = 0; i < 1000; ++i) {
    auto g = SteadySample(20, 0.5 * std::sin(i * 0.1), 0, 0, false);
    a.Add(g);
    b.Add(g);
    b.Add(g);  // same shape, twice the data
  }
  EXPECT_NEAR(KlDivergence(b.gg(), a.gg()), 0.0, 1e-3);
  Coverage c = b;
  for (int i = 0; i < 1000; ++i) c.Add(SteadySample(30, 3.0, 0, 0, false));  // a new region
  EXPECT_GT(KlDivergence(c.gg(), b.gg()), 0.1);
  EXPECT_NEAR(a.ShareBelow(1.0), 1.0, 1e-12);
  const Coverage back = Coverage::FromJson(JsonIn(ParseCbor(ToCbor(c.ToJson()), "t"), "coverage"));
  EXPECT_EQ(back.gg().counts, c.gg().counts);
}

}  // namespace
}  // namespace ndsid::stats
