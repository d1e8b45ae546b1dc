// SteadyStateStats and Coverage: merge, round trip, bins and edge cases, each against a direct
// computation in the test.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "ndsid/common/error.h"
#include "ndsid/stats/coverage.h"
#include "ndsid/stats/steady_state.h"

namespace ndsid::stats {
namespace {

gate::GatedSample Steady(double v, double ay, double steer, double r, bool yaw, double ax = 0) {
  gate::GatedSample g;
  g.verdict = gate::Verdict::kAccepted;
  g.quasi_steady = true;
  g.segment_start = true;  // a stretch of its own: one observation per sample
  g.sample.speed_mps = v;
  g.sample.lat_accel_mps2 = ay;
  g.sample.steer_rad = steer;
  g.sample.yaw_rate_radps = r;
  g.sample.has_yaw_rate = yaw;
  g.sample.long_accel_mps2 = ax;
  g.sample.has_long_accel = true;
  g.sample.valid = true;
  return g;
}

// Catches: "not determined" lost at constant speed, where a_y/v^2 = a_y / v0^2 and r/v = a_y/v0^2
// are proportional to a_y: the split of the steering between is*l and is*EG is unidentifiable,
// and any number reported for EG would be garbage.
TEST(SteadyStateStats, ConstantSpeedIsNotDetermined) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-3.5, 3.5);
  SteadyStateStats st;
  for (int i = 0; i < 2000; ++i) {
    const double v = 22.0, ay = u(rng), r = ay / v;
    st.Add(Steady(v, ay, 15.0 * (2.7 * r / v + 0.002 * ay), r, true));
  }
  for (bool yaw : {false, true}) {
    const SteadyStateEstimate e = st.Estimate(2.7, yaw);
    EXPECT_FALSE(e.valid) << "EG " << e.eg_rad_per_mps2;
    EXPECT_NE(e.reason.find("collinear"), std::string::npos) << e.reason;
    EXPECT_EQ(e.n, 2000);
  }
}

// Catches: samples that are not accepted or not quasi-steady leaking into the regression, and the
// yaw-rate regression fed without a yaw-rate signal.
TEST(SteadyStateStats, UsesOnlyAcceptedQuasiSteadySamples) {
  SteadyStateStats st;
  gate::GatedSample rejected = Steady(20, 1, 0.1, 0.05, true);
  rejected.verdict = gate::Verdict::kNonlinearRange;
  gate::GatedSample transient = Steady(20, 1, 0.1, 0.05, true);
  transient.quasi_steady = false;
  st.Add(rejected);
  st.Add(transient);
  EXPECT_EQ(st, SteadyStateStats{});
  st.Add(Steady(20, 1, 0.1, 0.05, false));
  EXPECT_EQ(st.without_yaw().n(), 1);
  EXPECT_EQ(st.with_yaw().n(), 0);
  // The regressors are the documented ones: (a_y/v^2, a_y, 1) and (r/v, a_y, 1).
  SteadyStateStats one;
  one.Add(Steady(20, 1, 0.1, 0.05, true));
  EXPECT_DOUBLE_EQ(one.without_yaw().xty()[0], 1.0 / 400 * 0.1);
  EXPECT_DOUBLE_EQ(one.with_yaw().xty()[0], 0.05 / 20 * 0.1);
  EXPECT_DOUBLE_EQ(one.with_yaw().xty()[1], 1.0 * 0.1);
  EXPECT_DOUBLE_EQ(one.with_yaw().xty()[2], 0.1);
}

// Catches: a steady-state merge that differs from feeding all samples (both regressions).
TEST(SteadyStateStats, MergedHalvesGiveTheSameEstimate) {
  std::mt19937_64 rng(32);
  std::uniform_real_distribution<double> uv(6, 35), ua(-3.5, 3.5);
  std::normal_distribution<double> noise(0, 1e-3);
  SteadyStateStats whole, a, b;
  for (int i = 0; i < 1000; ++i) {
    const double v = uv(rng), ay = ua(rng), r = ay / v;
    const gate::GatedSample g = Steady(v, ay, 15.0 * (2.7 * r / v + 0.002 * ay) + noise(rng), r, true);
    whole.Add(g);
    (i % 3 == 0 ? a : b).Add(g);
  }
  a.Merge(b);
  for (bool yaw : {false, true}) {
    const SteadyStateEstimate e0 = whole.Estimate(2.7, yaw), e1 = a.Estimate(2.7, yaw);
    ASSERT_TRUE(e0.valid && e1.valid);
    // Same sums in another order: the estimates agree far below their own standard error.
    EXPECT_NEAR(e1.eg_rad_per_mps2, e0.eg_rad_per_mps2, 1e-6 * e0.eg_se);
    EXPECT_NEAR(e1.steer_ratio, e0.steer_ratio, 1e-10 * e0.steer_ratio);
    EXPECT_NEAR(e1.eg_se, e0.eg_se, 1e-6 * e0.eg_se);
  }
}

// Catches: a steady-state document that loses one of its two regressions, or accepts a broken one.
TEST(SteadyStateStats, RoundTripAndMalformedDocument) {
  SteadyStateStats st;
  for (int i = 0; i < 30; ++i) st.Add(Steady(10 + i, 0.1 * i - 1.5, 0.01 * i, (0.1 * i - 1.5) / (10 + i), i % 2 == 0));
  auto back = [](const nlohmann::json& j) { return SteadyStateStats::FromJson(JsonIn(ParseCbor(ToCbor(j), "t"), "steady")); };
  EXPECT_EQ(back(st.ToJson()), st);
  EXPECT_EQ(back(SteadyStateStats{}.ToJson()), SteadyStateStats{});
  nlohmann::json j = st.ToJson();
  j.erase("with_yaw");
  EXPECT_THROW(back(j), CodecError);
  j = st.ToJson();
  j["without_yaw"] = nlohmann::json::object();
  EXPECT_THROW(back(j), CodecError);
  j = st.ToJson();
  j["with_yaw"]["xty"][2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(back(j), CodecError);
}

// Catches: bin arithmetic off by one at the edges, out-of-range values dropped instead of going
// to the edge bins (as documented), and non-finite values landing in some bin.
TEST(Histogram2d, EdgesAndOutOfRangeValuesGoToTheDocumentedBins) {
  Histogram2d h(-10, 10, 40, 0, 50, 20);  // 0.5 wide in x, 2.5 wide in y
  auto count = [&](int ix, int iy) { return h.counts[static_cast<size_t>(ix * h.ny + iy)]; };
  const double wx = (h.x_max - h.x_min) / h.nx, wy = (h.y_max - h.y_min) / h.ny;
  h.Add(h.x_min, h.y_min);              // lower edge: first bin
  EXPECT_EQ(count(0, 0), 1);
  h.Add(h.x_min + wx, h.y_min + wy);    // a bin's lower boundary belongs to that bin
  EXPECT_EQ(count(1, 1), 1);
  h.Add(std::nextafter(h.x_min + wx, h.x_min), h.y_min + 0.5 * wy);  // just below it: the bin before
  EXPECT_EQ(count(0, 0), 2);
  h.Add(h.x_max, h.y_max);              // upper edge: last bin
  EXPECT_EQ(count(h.nx - 1, h.ny - 1), 1);
  h.Add(-1e300, 1e300);                 // far outside: clamped to the edge bins
  EXPECT_EQ(count(0, h.ny - 1), 1);
  const double total = h.total();
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  h.Add(nan, 1);
  h.Add(1, inf);
  h.Add(-inf, 1);
  EXPECT_EQ(h.total(), total);          // non-finite values are not counted anywhere
  Histogram2d other(-10, 10, 4, 0, 50, 2);
  EXPECT_THROW(h.Merge(other), Error);
}

// Catches: a KL divergence that is not exactly zero for identical or proportional histograms
// (the daemon's "coverage growth is flat" test), negative, or off the textbook formula.
TEST(Histogram2d, KlDivergenceMatchesTheDefinition) {
  std::mt19937_64 rng(33);
  std::normal_distribution<double> g(0, 2);
  Histogram2d p(-10, 10, 40, -10, 10, 40), q = p;
  for (int i = 0; i < 5000; ++i) p.Add(g(rng), g(rng));
  for (int i = 0; i < 3000; ++i) q.Add(g(rng) + 1, 0.5 * g(rng));
  EXPECT_EQ(KlDivergence(p, p), 0.0);
  EXPECT_EQ(KlDivergence(Histogram2d(-1, 1, 4, -1, 1, 4), Histogram2d(-1, 1, 4, -1, 1, 4)), 0.0);
  Histogram2d p2 = p;
  p2.Merge(p);  // the same shape with twice the data: only the prior weighs differently
  EXPECT_GE(KlDivergence(p2, p), 0.0);
  EXPECT_LT(KlDivergence(p2, p), 1e-3);
  // The definition, with the prior of `prior` samples spread uniformly.
  for (double prior : {1.0, 10.0}) {
    const double k = static_cast<double>(p.counts.size()), alpha = prior / k;
    double tp = 0, tq = 0;
    for (size_t i = 0; i < p.counts.size(); ++i) tp += p.counts[i] + alpha, tq += q.counts[i] + alpha;
    double expected = 0;
    for (size_t i = 0; i < p.counts.size(); ++i) {
      const double pi = (p.counts[i] + alpha) / tp, qi = (q.counts[i] + alpha) / tq;
      expected += pi * std::log(pi / qi);
    }
    EXPECT_NEAR(KlDivergence(p, q, prior), expected, 1e-12 * expected);
    EXPECT_GT(KlDivergence(p, q, prior), 0.0);
  }
  EXPECT_EQ(KlDivergence(p, Histogram2d(-10, 10, 4, -10, 10, 4)), 0.0);  // shapes differ: documented 0
}

// Catches: coverage merge, round trip or ShareBelow disagreeing with a direct count.
TEST(Coverage, MergeRoundTripAndShareBelowAgreeWithDirectCounts) {
  std::mt19937_64 rng(34);
  std::normal_distribution<double> g(0, 1.5);
  std::uniform_real_distribution<double> uv(5, 45);
  Coverage whole, a, b;
  int below1 = 0, below2 = 0, n = 0;
  for (int i = 0; i < 4000; ++i) {
    const double ay = g(rng);
    gate::GatedSample s = Steady(uv(rng), ay, 0, 0, false, g(rng));
    if (i % 7 == 0) s.verdict = gate::Verdict::kBelowMinSpeed;  // not counted
    whole.Add(s);
    (i < 1500 ? a : b).Add(s);
    if (s.verdict != gate::Verdict::kAccepted) continue;
    ++n;
    below1 += std::abs(ay) < 1.0;  // bins are 0.5 m/s^2 wide, so |a_y| < 1 is whole bins
    below2 += std::abs(ay) < 2.0;
  }
  a.Merge(b);
  EXPECT_EQ(a.gg().counts, whole.gg().counts);      // integer-valued counts: exact
  EXPECT_EQ(a.v_ay().counts, whole.v_ay().counts);
  EXPECT_EQ(whole.gg().total(), n);
  EXPECT_DOUBLE_EQ(whole.ShareBelow(1.0), static_cast<double>(below1) / n);
  EXPECT_DOUBLE_EQ(whole.ShareBelow(2.0), static_cast<double>(below2) / n);
  EXPECT_EQ(Coverage{}.ShareBelow(1.0), 0.0);  // empty: 0, not NaN

  const Coverage back = Coverage::FromJson(JsonIn(ParseCbor(ToCbor(whole.ToJson()), "t"), "coverage"));
  EXPECT_EQ(back.gg().counts, whole.gg().counts);
  EXPECT_EQ(back.v_ay().counts, whole.v_ay().counts);
  const Coverage empty_back = Coverage::FromJson(JsonIn(Coverage{}.ToJson(), "coverage"));
  EXPECT_EQ(empty_back.gg().total(), 0.0);
}

// Catches: a short, padded or corrupted coverage document restored as a different histogram.
TEST(Coverage, MalformedDocumentIsRejected) {
  Coverage c;
  c.Add(Steady(20, 1, 0, 0, false));
  const nlohmann::json good = c.ToJson();
  auto rejected = [&](const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json j = good;
    edit(j);
    EXPECT_THROW(Coverage::FromJson(JsonIn(j, "coverage")), CodecError) << j.dump();
  };
  rejected([](nlohmann::json& j) { j = nlohmann::json::object(); });
  rejected([](nlohmann::json& j) { j["gg"].erase(j["gg"].size() - 1); });   // last count missing
  rejected([](nlohmann::json& j) { j["v_ay"].push_back(1.0); });            // one count too many
  rejected([](nlohmann::json& j) { j["gg"][0] = -1.0; });                   // negative
  rejected([](nlohmann::json& j) { j["v_ay"][3] = std::numeric_limits<double>::infinity(); });
  rejected([](nlohmann::json& j) { j["gg"] = "0 0 0"; });
}

}  // namespace
}  // namespace ndsid::stats
