// The ladder's steady-state evidence (docs/two-outputs.md, "Steady-state evidence"): the
// intercept of the steady-state regression reads a steering offset (or an a_y bias) that the
// climb's ranking, taken at a fit that fails for a reason outside the library, did not try.
// Through the whole pipeline: simulator -> CAN log -> decode -> gate -> window -> ladder.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "ndsid/discover/diagnosis.h"
#include "sim_harness.h"

namespace ndsid::testing {
namespace {

struct Climbed {
  discover::Ladder ladder;
  double eg_truth = 0;
  double steer_offset_truth_rad = 0;
};

// The ladder as `ndsid diagnose` runs it on the example vehicle's configuration (both outputs,
// from road_bank and gyro_offset; its evidence from the replayed window).
Climbed Climb(const std::string& name, uint64_t seed, const std::vector<std::string>& hidden) {
  const SimulatedRun run = SimulateAndReplay(name, seed, 0.7, hidden);
  config::IdentificationConfig cfg = run.config->identification;
  cfg.yaw_rate_output = true;
  discover::LadderOptions options;
  options.standstill = run.window.standstill;
  options.speed_scale_evidence = stats::EstimateSpeedScale(run.window.training);
  options.steady_state = run.window.steady_state;
  Climbed c;
  c.ladder = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank", "gyro_offset"},
                                        model::EffectLibrary::Builtin(), run.window.training, run.window.validation, options);
  c.eg_truth = run.eg_truth;
  c.steer_offset_truth_rad = run.sim.effects.steer_offset_deg * M_PI / 180;
  const stats::SteadyStateEstimate& ss = run.window.steady_state;
  std::printf("%s (seed %llu): steady-state intercept %.5f +- %.5f rad (valid %d)\n", name.c_str(),
              static_cast<unsigned long long>(seed), ss.steer_offset_rad, ss.steer_offset_se, ss.valid);
  for (const discover::Trial& t : c.ladder.trials) std::printf("  %-16s %s\n", t.effect.c_str(), t.why.c_str());
  std::printf("  final:");
  for (const std::string& e : c.ladder.final_effects) std::printf(" %s", e.c_str());
  std::printf("\n");
  return c;
}

bool Has(const std::vector<std::string>& effects, const std::string& e) {
  return std::find(effects.begin(), effects.end(), e) != effects.end();
}

// The trials the steady-state step made.
std::vector<discover::Trial> SteadyStateTrials(const discover::Ladder& ladder) {
  std::vector<discover::Trial> out;
  for (const discover::Trial& t : ladder.trials)
    if (t.why.find("steady-state evidence") != std::string::npos) out.push_back(t);
  return out;
}

// Catches: a steering offset the intercept reads left out because the ranking, at a fit that
// fails on a steering dead band (outside the library), put three other candidates first. Seeds,
// signs and the dead band's width varied. Stated tolerance: the recovered offset within 35 % of
// the truth (the dead band the model lacks takes its share of the intercept: measured 14-22 %);
// the held-out a_y falls (by the climb's 3 % margin; measured -17.0 and -22.5 %); an a_y bias in
// its place (the two explain the intercept alike without stops) must have the opposite sign.
// Seeds 527 and 528 the climb finds itself; at least one case must need the step.
TEST(SteadyStateEvidence, AnOffsetTheRankingMissedIsAddedFromTheIntercept) {
  struct Case {
    uint64_t seed;
    std::vector<std::string> hidden;
  };
  const Case cases[] = {{512, {"steer_offset_deg=-1", "steer_deadband_deg=2"}},
                        {524, {"steer_offset_deg=1.5", "steer_deadband_deg=2"}},
                        {527, {"steer_offset_deg=-1.5", "steer_deadband_deg=2"}},
                        {528, {"steer_offset_deg=2", "steer_deadband_deg=3"}}};
  int added_by_evidence = 0;
  for (const Case& k : cases) {
    const Climbed c = Climb("ss_offset_" + std::to_string(k.seed), k.seed, k.hidden);
    const bool offset = Has(c.ladder.final_effects, "steer_offset"), bias = Has(c.ladder.final_effects, "accel_bias");
    EXPECT_TRUE(offset || bias) << "seed " << k.seed << ": neither a steering offset nor an a_y bias in the final model";
    for (const discover::Trial& t : SteadyStateTrials(c.ladder)) {
      if (!t.accepted) continue;
      ++added_by_evidence;
      EXPECT_LT(t.held_out_after, t.held_out_before) << "seed " << k.seed << ": " << t.why;
    }
    // What is said after the ladder reads the final model's residual: its ranking is the last,
    // and the dead band the library lacks leads the signatures there (desk/outside_library.h).
    ASSERT_FALSE(c.ladder.diagnoses.empty());
    const discover::Diagnosis& last = c.ladder.diagnoses.back();
    EXPECT_EQ(last.model, c.ladder.rungs.back().model) << "seed " << k.seed;
    ASSERT_FALSE(last.signatures.empty());
    std::printf("  last diagnosis's leading signature: %s (z %+.1f)\n", last.signatures.front().key.c_str(),
                last.signatures.front().z_robust);
    EXPECT_EQ(last.signatures.front().key, "steer_odd") << "seed " << k.seed;
    for (const auto& p : c.ladder.rungs.back().fit.effect_params) {
      if (p.name == "steer_offset_rad")
        EXPECT_NEAR(p.value, c.steer_offset_truth_rad, 0.35 * std::abs(c.steer_offset_truth_rad)) << "seed " << k.seed;
      if (p.name == "accel_bias_mps2") EXPECT_LT(p.value * c.steer_offset_truth_rad, 0.0) << "seed " << k.seed << ": its sign";
    }
  }
  EXPECT_GE(added_by_evidence, 1) << "the climb found every offset itself: these cases no longer test the step";
}

// Catches: an intercept the model already explains turned into an effect. Clean drives (the
// intercept within 3 standard errors of what the model leaves, or its refit undetermined) and a
// hidden a_y bias that the climb's steering offset already stands for.
TEST(SteadyStateEvidence, NoOffsetWhereTheModelExplainsTheIntercept) {
  for (const uint64_t seed : {521, 522}) {
    const Climbed c = Climb("ss_clean_" + std::to_string(seed), seed, {});
    for (const discover::Trial& t : SteadyStateTrials(c.ladder)) EXPECT_FALSE(t.accepted) << "seed " << seed << ": " << t.why;
    EXPECT_FALSE(Has(c.ladder.final_effects, "steer_offset")) << "seed " << seed;
  }
  // The climb's own choice between the two is the confounding docs/two-outputs.md describes; the
  // step adds neither here: the model's steering offset already implies the intercept.
  const Climbed b = Climb("ss_bias_523", 523, {"accel_bias_mps2=0.12"});
  for (const discover::Trial& t : SteadyStateTrials(b.ladder)) EXPECT_FALSE(t.accepted) << t.why;
}

}  // namespace
}  // namespace ndsid::testing
