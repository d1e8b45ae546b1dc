// The checks of the fit (fit_checks.h) on the facts a fit hands over: each rule passes a fit that
// meets it, fails one that breaks it with the numbers and the cause in its message, and skips
// where nothing can be judged. The limits are the documented defaults.
#include "ndsid/adequacy/fit_checks.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ndsid::adequacy {
namespace {

// A fit that passes every check: converged, a_y at 1.1x its floor, nothing on a bound, the
// steady state and the halves agreeing.
FitFacts Good() {
  FitFacts f;
  f.termination = "CONVERGENCE";
  f.iterations = 12;
  f.outputs = {{.output = "a_y", .unit = "m/s^2", .rmse = 0.044, .floor = 0.040, .spread = 1.2, .residuals = 100000},
               {.output = "yaw_rate", .unit = "deg/s", .rmse = 0.07, .floor = 0.06, .spread = 6.0, .residuals = 100000}};
  f.eg_deg_per_g = 4.19;
  f.eg_se_deg_per_g = 0.01;
  f.steady_state_valid = true;
  f.steady_state_eg_deg_per_g = 4.13;
  f.steady_state_eg_se_deg_per_g = 0.02;
  f.halves = std::make_pair(HalfFacts{.valid = true, .reason = "", .eg_deg_per_g = 4.18, .eg_se_deg_per_g = 0.014, .drives = 3},
                            HalfFacts{.valid = true, .reason = "", .eg_deg_per_g = 4.21, .eg_se_deg_per_g = 0.014, .drives = 2});
  f.window_drives = 5;
  return f;
}

const Check& Find(const PlausibilityReport& r, const std::string& name) {
  for (const Check& c : r.checks)
    if (c.name == name) return c;
  throw std::runtime_error("no check " + name);
}

PlausibilityReport Checked(const FitFacts& f) {
  PlausibilityReport r;
  CheckFit(f, config::PlausibilityConfig{}, r);
  return r;
}

TEST(FitChecks, AGoodFitPassesEveryCheck) {
  const PlausibilityReport r = Checked(Good());
  EXPECT_TRUE(r.passed()) << r.Reason();
  EXPECT_EQ(r.checks.size(), 6u);  // converged, explained x2, bounds, steady_state, halves
}

TEST(FitChecks, AFitStoppedAtItsIterationCapIsNotValid) {
  FitFacts f = Good();
  f.termination = "NO_CONVERGENCE";
  f.iterations = 100;
  const Check& c = Find(Checked(f), "converged");
  EXPECT_EQ(c.verdict, Verdict::kFailed);
  EXPECT_NE(c.message.find("iteration cap"), std::string::npos) << c.message;
}

TEST(FitChecks, AResidualAtTheSignalsSizeFailsWhateverTheFloor) {
  FitFacts f = Good();
  f.outputs[0].rmse = 20.8;
  f.outputs[0].floor = 7.0;  // a vibrating accelerometer: a high floor hides nothing here
  f.outputs[0].spread = 3.0;
  const Check& c = Find(Checked(f), "explained_a_y");
  EXPECT_EQ(c.verdict, Verdict::kFailed);
  EXPECT_NE(c.message.find("does not follow the signal"), std::string::npos) << c.message;
}

TEST(FitChecks, AResidualFarAboveItsFloorIsUnexplainedStructure) {
  FitFacts f = Good();
  f.outputs[0].rmse = 0.36;
  f.outputs[0].floor = 0.038;  // 9.5x
  const Check& c = Find(Checked(f), "explained_a_y");
  EXPECT_EQ(c.verdict, Verdict::kFailed);
  EXPECT_NEAR(c.value, 0.36 / 0.038, 1e-9);
  EXPECT_NE(c.message.find("structure the model lacks"), std::string::npos) << c.message;
  f.outputs[0].rmse = 0.19;  // 5.0x: at the limit
  EXPECT_EQ(Find(Checked(f), "explained_a_y").verdict, Verdict::kPassed);
}

// Noise-free data (a simulator's output without sensor noise): the white floor is the DBC's
// quantisation, and a residual of 1 % of the signal lies many floors above it. Below 5 % of the
// spread the floor does not judge; above it, it does again.
TEST(FitChecks, AResidualNegligibleAgainstTheSignalPassesWhateverTheFloor) {
  FitFacts f = Good();
  f.outputs[0].rmse = 0.0162;
  f.outputs[0].floor = 0.0023;  // 7x
  f.outputs[0].spread = 0.93;   // 1.7 %
  const Check& c = Find(Checked(f), "explained_a_y");
  EXPECT_EQ(c.verdict, Verdict::kPassed) << c.message;
  EXPECT_NEAR(c.value, 0.0162 / 0.0023, 1e-9);
  EXPECT_NE(c.message.find("negligible whatever the floor"), std::string::npos) << c.message;
  f.outputs[0].rmse = 0.06;  // 6.5 % of the spread, 26x the floor
  const Check& above = Find(Checked(f), "explained_a_y");
  EXPECT_EQ(above.verdict, Verdict::kFailed) << above.message;
  EXPECT_NE(above.message.find("structure the model lacks"), std::string::npos) << above.message;
  EXPECT_EQ(Find(Checked(Good()), "explained_a_y").message.find("negligible"), std::string::npos);  // judged by its floor
}

TEST(FitChecks, AParameterOnItsBoundFailsOnlyWhenReleasingItWouldMoveEg) {
  FitFacts f = Good();  // sigma(EG) 0.01 deg/g
  f.at_bound = {{.name = "Jz", .value = 3200, .eg_correlation = 0.05, .eg_shift_deg_per_g = 0.001}};
  f.eg_bound_shift_deg_per_g = 0.001;  // 0.1 sigma: the bound holds Jz, not EG
  EXPECT_EQ(Find(Checked(f), "bounds").verdict, Verdict::kPassed);
  f.at_bound.push_back({.name = "ch", .value = 135000, .eg_correlation = -0.3, .eg_shift_deg_per_g = -0.05});
  f.eg_bound_shift_deg_per_g = -0.049;  // 4.9 sigma
  const Check& c = Find(Checked(f), "bounds");
  EXPECT_EQ(c.verdict, Verdict::kFailed);
  EXPECT_NEAR(c.value, -4.9, 1e-9);
  EXPECT_NE(c.message.find("ch = 1.35e+05 (EG -0.050 deg/g if released"), std::string::npos) << c.message;
  EXPECT_NE(c.message.find("the box, not the data, sets EG"), std::string::npos) << c.message;
}

TEST(FitChecks, DynamicEgContradictingTheSteadyStateIsNotValid) {
  FitFacts f = Good();
  f.eg_deg_per_g = 11.8;
  f.eg_se_deg_per_g = 1.8;
  f.steady_state_eg_deg_per_g = 1.8;
  f.steady_state_eg_se_deg_per_g = 0.1;
  const Check& c = Find(Checked(f), "steady_state");
  EXPECT_EQ(c.verdict, Verdict::kFailed);
  EXPECT_GT(c.value, 3.0);
  f.steady_state_valid = false;
  EXPECT_EQ(Find(Checked(f), "steady_state").verdict, Verdict::kSkipped);
}

TEST(FitChecks, TheRegressionsBiasAllowanceIsAShareOfEg) {
  // 4 % apart with tiny sigmas: within the 10 % bias allowance, not 30 sigma.
  FitFacts f = Good();
  f.eg_deg_per_g = 4.30;
  f.eg_se_deg_per_g = 0.001;
  f.steady_state_eg_deg_per_g = 4.13;
  f.steady_state_eg_se_deg_per_g = 0.001;
  EXPECT_EQ(Find(Checked(f), "steady_state").verdict, Verdict::kPassed);
}

TEST(FitChecks, HalvesThatDisagreeFailAndTooFewDrivesSkip) {
  FitFacts f = Good();
  f.halves->first.eg_deg_per_g = 3.0;
  f.halves->second.eg_deg_per_g = 3.5;
  f.halves->first.eg_se_deg_per_g = f.halves->second.eg_se_deg_per_g = 0.1;  // 3.5 sigma
  const Check& c = Find(Checked(f), "halves");
  EXPECT_EQ(c.verdict, Verdict::kFailed);
  EXPECT_NEAR(std::abs(c.value), 0.5 / std::hypot(0.1, 0.1), 1e-9);
  f.halves.reset();
  f.window_drives = 1;
  EXPECT_EQ(Find(Checked(f), "halves").verdict, Verdict::kSkipped);
  FitFacts g = Good();
  g.halves->second.valid = false;
  g.halves->second.reason = "solver failed";
  const Check& h = Find(Checked(g), "halves");
  EXPECT_EQ(h.verdict, Verdict::kFailed);
  EXPECT_NE(h.message.find("solver failed"), std::string::npos);
}

TEST(FitChecks, FloorFromLagSumsIsTheFirstDifferenceFloor) {
  // White noise of sd 0.3: the first-difference floor sqrt(sum (de)^2 / 2n) is 0.3.
  std::vector<double> e;
  uint64_t x = 88172645463325252ull;
  for (int k = 0; k < 200000; ++k) {  // xorshift + Box-Muller: deterministic, no <random> distribution
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    const double u1 = (static_cast<double>(x >> 11) + 0.5) / 9007199254740992.0;
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;
    const double u2 = static_cast<double>(x >> 11) / 9007199254740992.0;
    e.push_back(0.3 * std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2));
  }
  double s0 = 0, s1 = 0, d2 = 0;
  for (size_t k = 1; k < e.size(); ++k) {
    s0 += e[k] * e[k];
    s1 += e[k] * e[k - 1];
    d2 += (e[k] - e[k - 1]) * (e[k] - e[k - 1]);
  }
  const double n = static_cast<double>(e.size() - 1);
  EXPECT_NEAR(FloorFromSums(s0, s1, n), std::sqrt(d2 / (2 * n)), 2e-3);
  EXPECT_NEAR(FloorFromSums(s0, s1, n), 0.3, 3e-3);
  EXPECT_LT(FloorFromSums(1, 0, 0), 0);
}

}  // namespace
}  // namespace ndsid::adequacy
