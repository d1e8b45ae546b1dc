// The coarse start of large whole-window fits (IdentificationConfig::coarse_min_chunks): the
// solver first runs on an interleaved subset of the chunks, then on all of them. It may only
// save iterations: the result must be the whole window's optimum, as without it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "ndsid/identify/identifier.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

namespace t = ndsid::testing;
using t::kWheelbase;
using t::Pointers;

constexpr double kDeg = M_PI / 180.0;

// Every estimate with and without the coarse start, in standard errors of the fit without it;
// the standard error of EG within se_tol (relative).
void ExpectSameOptimum(const IdentificationResult& off, const IdentificationResult& on, double tol_sigma, double se_tol) {
  ASSERT_TRUE(off.valid) << off.reason;
  ASSERT_TRUE(on.valid) << on.reason;
  EXPECT_LE(std::abs(on.eg_rad_per_mps2 - off.eg_rad_per_mps2), tol_sigma * off.eg_se_rad_per_mps2);
  EXPECT_NEAR(on.eg_se_rad_per_mps2, off.eg_se_rad_per_mps2, se_tol * off.eg_se_rad_per_mps2);
  for (int i = 0; i < model::kNumParams; ++i) {
    if (off.params[i].fixed) continue;
    EXPECT_LE(std::abs(on.params[i].value - off.params[i].value), tol_sigma * off.params[i].se) << off.params[i].name;
  }
  ASSERT_EQ(on.effect_params.size(), off.effect_params.size());
  for (size_t i = 0; i < off.effect_params.size(); ++i) {
    EXPECT_LE(std::abs(on.effect_params[i].value - off.effect_params[i].value), tol_sigma * off.effect_params[i].se)
        << off.effect_params[i].name;
  }
  EXPECT_NEAR(on.rmse_train_mps2, off.rmse_train_mps2, 1e-3 * off.rmse_train_mps2);
}

// Catches: a coarse start that leaves the fit at the subset's optimum (the finishing solve not run
// or stopped early), that loses the fixed set, bounds or output weights, or that is not used.
// Two outputs with road_bank and gyro_offset (crossfall per segment, a 0.3 deg/s offset) and a_y
// alone with the base model, two seeds each; 36 chunks, the coarse start on every 3rd.
TEST(CoarseStart, ReachesTheWholeWindowsOptimum) {
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"crossfall", "gyro_offset"});
  std::vector<double> truth = t::TruthVector();
  truth.push_back(0.0);  // crossfall, drawn per segment
  truth.push_back(0.3 * kDeg);
  const double eg_true = model::SelfSteerGradient(t::TruthParams(), kWheelbase);
  for (const bool two_outputs : {true, false}) {
    for (const uint64_t seed : {71u, 72u}) {
      // a_y alone: the base model's own data (no crossfall, no gyro offset).
      const auto train = two_outputs ? t::SyntheticTwoOutputSegments(truth_spec, truth, 36, 60, 0.05, 0.1 * kDeg, seed, 0.2)
                                     : t::SyntheticTwoOutputSegments(model::ModelSpec(), t::TruthVector(), 36, 60, 0.05, 0.1 * kDeg, seed);
      config::IdentificationConfig cfg = t::DefaultIdentificationConfig();
      cfg.yaw_rate_output = two_outputs;
      const model::ModelSpec spec =
          two_outputs ? model::ModelSpec::FromNames({"road_bank", "gyro_offset"}) : model::ModelSpec();
      cfg.coarse_min_chunks = 0;
      const IdentificationResult off = Identifier(cfg, kWheelbase, spec).Identify(Pointers(train), {});
      cfg.coarse_min_chunks = 20;
      cfg.coarse_chunks = 12;
      const IdentificationResult on = Identifier(cfg, kWheelbase, spec).Identify(Pointers(train), {});
      std::printf("%s seed %llu: without %d iterations, with %d on the subset + %d; EG %+.4f%% vs %+.4f%% (se %.3f%%)\n",
                  two_outputs ? "two outputs" : "a_y alone", static_cast<unsigned long long>(seed), off.iterations,
                  on.coarse_iterations, on.iterations, 100 * (off.eg_rad_per_mps2 / eg_true - 1),
                  100 * (on.eg_rad_per_mps2 / eg_true - 1), 100 * off.eg_se_rad_per_mps2 / eg_true);
      EXPECT_EQ(off.coarse_iterations, 0);
      EXPECT_GT(on.coarse_iterations, 0);
      EXPECT_TRUE(on.coarse_start_used);
      // Fewer whole-window iterations is what it is for, but on a window this small the whole
      // window converges from the start about as fast: bench/run_identify_bench.sh measures it.
      // a_y alone: the same problem from another start, so the same optimum to the solver's
      // tolerance. Two outputs: the output weights come from the coarse solution instead of the
      // start values (refitted there when they moved 1.5x), so the two problems differ by at
      // most that much weighting between the outputs: 0.1 sigma, and 5 % in EG's standard error.
      if (two_outputs) {
        ExpectSameOptimum(off, on, 0.1, 0.05);
      } else {
        ExpectSameOptimum(off, on, 0.02, 0.01);
      }
      // And the optimum is right: the truth within 4 standard errors.
      EXPECT_LT(std::abs(on.eg_rad_per_mps2 - eg_true), 4 * on.eg_se_rad_per_mps2);
    }
  }
}

// Catches: a coarse start that replaces a warm start already at the whole window's optimum (the
// daemon's scheduled refits start from the last fit): the subset's solution lies a subset's
// scatter away from it, so the start must be kept, and the fit must end where it began.
TEST(CoarseStart, AWarmStartAtTheOptimumIsKept) {
  for (const bool two_outputs : {true, false}) {
    const auto train = t::SyntheticTwoOutputSegments(model::ModelSpec(), t::TruthVector(), 36, 60, 0.05, 0.1 * kDeg, 74);
    config::IdentificationConfig cfg = t::DefaultIdentificationConfig();
    cfg.yaw_rate_output = two_outputs;
    cfg.coarse_min_chunks = 20;
    cfg.coarse_chunks = 12;
    const Identifier id(cfg, kWheelbase);
    const IdentificationResult cold = id.Identify(Pointers(train), {});
    ASSERT_TRUE(cold.valid) << cold.reason;
    EXPECT_TRUE(cold.coarse_start_used);
    const IdentificationResult warm = id.Identify(Pointers(train), {}, std::optional<std::vector<double>>(cold.AllValues()));
    ASSERT_TRUE(warm.valid) << warm.reason;
    std::printf("%s: cold %d + %d iterations, warm from its result %d + %d (coarse used: %d)\n",
                two_outputs ? "two outputs" : "a_y alone", cold.coarse_iterations, cold.iterations, warm.coarse_iterations,
                warm.iterations, warm.coarse_start_used);
    EXPECT_GT(warm.coarse_iterations, 0);
    EXPECT_FALSE(warm.coarse_start_used);
    EXPECT_LE(std::abs(warm.eg_rad_per_mps2 - cold.eg_rad_per_mps2), 0.02 * cold.eg_se_rad_per_mps2);
  }
}

// Catches: a coarse start below its threshold (small windows must run as before).
TEST(CoarseStart, NotUsedBelowItsThreshold) {
  const auto train = t::SyntheticTwoOutputSegments(model::ModelSpec(), t::TruthVector(), 12, 60, 0.05, 0.1 * kDeg, 73);
  config::IdentificationConfig cfg = t::DefaultIdentificationConfig();
  cfg.coarse_min_chunks = 13;
  cfg.coarse_chunks = 4;
  const IdentificationResult r = Identifier(cfg, kWheelbase).Identify(Pointers(train), {});
  ASSERT_TRUE(r.valid) << r.reason;
  EXPECT_EQ(r.coarse_iterations, 0);
  cfg.coarse_min_chunks = 12;
  EXPECT_GT(Identifier(cfg, kWheelbase).Identify(Pointers(train), {}).coarse_iterations, 0);
}

}  // namespace
}  // namespace ndsid::identify
