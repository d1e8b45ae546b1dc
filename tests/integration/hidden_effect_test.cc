// The model-improvement loop proven on simulated driving with hidden effects (issue: compare
// -> where it fails -> which effect is missing -> add it -> the error falls). Through the whole
// pipeline: simulator -> CAN log -> decode -> gate -> window -> fit -> diagnosis -> ladder.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ndsid/identify/diagnosis.h"
#include "sim_harness.h"

namespace ndsid::testing {
namespace {

struct HiddenCase {
  const char* name;
  std::vector<std::string> simulated;   // simulator assignments
  std::vector<std::string> expected;    // effects the ladder must add (in any order)
  std::vector<std::string> confounded;  // if set: the ladder adds exactly one effect of this group
  const char* param;                    // a recovered parameter to check ("" = none)
  double truth_value;                   // in the model's unit
  double tolerance;
};

void PrintDiagnosis(const identify::Diagnosis& d) {
  for (const auto& c : d.ranked) {
    std::printf("  %-16s dRSS %.3g  one-step %+.4g %s  uniq %.2f  z %+.1f%s\n", c.effect.c_str(), c.drss, c.one_step,
                c.unit.c_str(), c.uniqueness, c.z_robust, c.significant ? "  significant" : "");
  }
  if (d.unexplained) std::printf("  UNEXPLAINED: %s\n", d.unexplained_text.c_str());
}

void RunCase(const HiddenCase& c, uint64_t seed, double hours) {
  const SimulatedRun run = SimulateAndReplay(c.name, seed, hours, c.simulated);
  const auto& cfg = run.config->identification;
  const identify::Ladder ladder = identify::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank"},
                                                             run.window.training, run.window.validation);
  ASSERT_FALSE(ladder.rungs.empty());
  ASSERT_FALSE(ladder.diagnoses.empty());
  std::printf("%s: first diagnosis\n", c.name);
  PrintDiagnosis(ladder.diagnoses.front());
  for (const auto& r : ladder.rungs) {
    std::printf("  rung %-40s RMSE %.4f / %.4f  EG %.4f ± %.4f deg/g\n", r.model.c_str(), r.fit.rmse_train_mps2,
                r.fit.rmse_validation_mps2, r.fit.eg_deg_per_g, r.fit.eg_se_deg_per_g);
  }
  std::printf("  stop: %s\n", ladder.stop_reason.c_str());
  std::vector<std::string> added;
  for (size_t i = 1; i < ladder.rungs.size(); ++i) added.push_back(ladder.rungs[i].added);
  const std::string& first = ladder.diagnoses.front().ranked.front().effect;
  if (!c.confounded.empty()) {
    // Physically confounded with the model's other terms: one member of the group, any.
    auto in_group = [&](const std::string& e) { return std::find(c.confounded.begin(), c.confounded.end(), e) != c.confounded.end(); };
    EXPECT_TRUE(in_group(first)) << "ranked first: " << first;
    ASSERT_EQ(added.size(), 1u);
    EXPECT_TRUE(in_group(added[0])) << added[0];
  } else {
    // The hidden effect is ranked first by the score test, and the ladder adds exactly it.
    if (!c.expected.empty()) {
      EXPECT_NE(std::find(c.expected.begin(), c.expected.end(), first), c.expected.end()) << "ranked first: " << first;
    }
    std::vector<std::string> want = c.expected;
    std::sort(added.begin(), added.end());
    std::sort(want.begin(), want.end());
    EXPECT_EQ(added, want);
  }
  const identify::IdentificationResult& final_fit = ladder.rungs.back().fit;
  // The error falls to the noise floor: the true model's RMSE (the simulated effects at their
  // true values) on the same held-out drives.
  std::vector<std::string> truth_effects{"road_bank"};
  for (const auto& e : c.expected) truth_effects.push_back(e);
  const auto spec = model::ModelSpec::FromNames(truth_effects);
  const identify::Identifier truth_model(cfg, run.config->vehicle.wheelbase_m, spec);
  const double floor = truth_model.Rmse(TruthVector(run, spec), run.window.validation);
  std::printf("  validation RMSE %.4f, noise floor %.4f\n", final_fit.rmse_validation_mps2, floor);
  EXPECT_LT(final_fit.rmse_validation_mps2, 1.10 * floor);
  if (!c.expected.empty()) EXPECT_LT(final_fit.rmse_validation_mps2, ladder.rungs.front().fit.rmse_validation_mps2);
  // The effect's parameter is recovered; EG's bias from the hidden effect is gone (within the
  // ~1-2 % the clean model leaves, docs/accuracy.md).
  if (*c.param && c.confounded.empty()) {
    bool found = false;
    for (const auto& p : final_fit.effect_params) {
      if (p.name != c.param) continue;
      found = true;
      EXPECT_NEAR(p.value, c.truth_value, c.tolerance) << p.name;
    }
    EXPECT_TRUE(found) << c.param;
  }
  EXPECT_LT(std::abs(final_fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.03);
}

// Catches: a diagnosis that misses a steering-angle offset, or a ladder that does not add it.
TEST(HiddenEffect, SteerOffsetFoundAddedAndErrorFalls) {
  RunCase({"steer_offset", {"steer_offset_deg=1.5"}, {"steer_offset"}, {}, "steer_offset_rad", 1.5 * M_PI / 180, 0.003},
          41, 1.5);
}

// Catches: false discoveries on clean data (the robust score test must stay quiet).
TEST(HiddenEffect, CleanDataNothingSignificantIsAdded) {
  RunCase({"none", {}, {}, {}, "", 0, 0}, 42, 1.5);
}

// With road_bank in the model, a bias b enters the bank estimate (v r - a_meas): the model then
// reproduces b l/L and leaves b EG v^2/L, exactly a steering offset's signature. Measured: the
// ladder adds steer_offset and reaches the noise floor. The tools cannot tell these apart from
// (d_sw, v, a_y, r) without standstill data or a prior; the test asserts one of the group.
TEST(HiddenEffectLong, AccelerometerBiasConfoundedWithSteerOffsetThroughTheBank) {
  RunCase({"bias", {"accel_bias_mps2=0.1"}, {"accel_bias"}, {"accel_bias", "steer_offset", "crossfall"},
           "accel_bias_mps2", 0.1, 0.015},
          43, 1.5);
}

// Measured: 80 ms hidden, recovered 56 ms (its sensitivity is only 21 % unique: a steering lag
// trades with lv and Jz); the stated tolerance is +-32 ms (40 %).
TEST(HiddenEffectLong, SteeringTimeSkew) {
  RunCase({"delay", {"steer_delay_ms=80"}, {"steer_delay"}, {}, "steer_delay_s", 0.08, 0.032}, 44, 1.5);
}

TEST(HiddenEffectLong, TwoEffectsFoundOneAfterTheOther) {
  RunCase({"two", {"steer_offset_deg=1.5", "steer_delay_ms=80"}, {"steer_offset", "steer_delay"}, {}, "steer_offset_rad",
           1.5 * M_PI / 180, 0.003},
          45, 1.5);
}

// Catches: an effect outside the candidate list forced onto the nearest candidate. A 120 ms
// steering skew is hidden and the lag effects (steer_delay, relaxation) are removed from the
// candidates: the residual must be reported as unexplained, correlating with the steering rate.
// (Tyre saturation was tried first: at mu 0.6 it hardly shows inside the gated linear range of
// naturalistic driving, as the study observed, so it is no probe.)
TEST(HiddenEffectLong, EffectOutsideTheLibraryIsReportedUnexplained) {
  const SimulatedRun run = SimulateAndReplay("outside", 46, 1.5, {"steer_delay_ms=120"});
  const identify::Identifier id(run.config->identification, run.config->vehicle.wheelbase_m,
                                model::ModelSpec::FromNames({"road_bank"}));
  const auto fit = id.Identify(run.window.training, run.window.validation, std::optional<std::vector<double>>{});
  ASSERT_TRUE(fit.valid);
  identify::DiagnosisOptions opt;
  for (const auto& n : model::BuiltinEffectNames()) {
    if (n != "steer_delay" && n != "relaxation" && n != "road_bank") opt.candidates.push_back(n);
  }
  const identify::Diagnosis d = identify::Diagnose(id, fit.AllValues(), run.window.training, opt);
  PrintDiagnosis(d);
  for (const auto& s : d.signatures) std::printf("  signature %-45s r %+.3f z %+.1f\n", s.signal.c_str(), s.correlation, s.z_robust);
  EXPECT_TRUE(d.unexplained) << "expected unexplained structure";
  EXPECT_NE(d.unexplained_text.find("steering rate"), std::string::npos) << d.unexplained_text;
}

}  // namespace
}  // namespace ndsid::testing

