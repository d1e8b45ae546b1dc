// The ladder's EG-relevant rule (LadderOptions::eg_relevant_*) on
// synthetic two-output segments: a body roll the tracked bank absorbs is added although no
// held-out RMSE falls by the ladder's 3 %, because both fall and EG moves far beyond its sigma;
// a candidate that moves EG but is not added leaves EG reported unsettled.
#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/discover/diagnosis.h"
#include "synthetic_segments.h"
#include "verdicts.h"

namespace ndsid::testing {
namespace {

constexpr double kNoiseA = 0.05;                 // m/s^2
constexpr double kNoiseR = 0.1 * M_PI / 180.0;  // rad/s

discover::Ladder Climb(const std::vector<stats::Segment>& train, const std::vector<stats::Segment>& valid,
                       std::vector<std::string> candidates, double eg_relevant_min_improvement = 0.01, int max_steps = 1) {
  // The ladder's ordinary rule (a held-out RMSE falls by min_relative_improvement) is put out of
  // reach, so what is added here is added by the EG-relevant rule alone. (On these synthetic
  // drives, with their brisk random steering, roll 5 deg/g also lowers the held-out RMSE by 7 %;
  // in the simulator's everyday driving by 1.4 %: HiddenEffectLong.BodyRollFoundWithTwoOutputs*.)
  config::IdentificationConfig c = DefaultIdentificationConfig();
  c.yaw_rate_output = true;
  discover::LadderOptions o;
  o.align = false;
  o.max_steps = max_steps;
  o.min_relative_improvement = 1.0;
  o.eg_relevant_min_improvement = eg_relevant_min_improvement;
  o.diagnosis.candidates = std::move(candidates);
  const discover::Ladder l = discover::ClimbErrorLadder(c, kWheelbase, {"road_bank"}, model::EffectLibrary::Builtin(),
                                                        Pointers(train), Pointers(valid), o);
  for (const auto& r : l.rungs) std::printf("  rung %-36s EG %.4f ± %.4f deg/g\n", r.model.c_str(), r.fit.eg_deg_per_g, r.fit.eg_se_deg_per_g);
  if (!l.diagnoses.empty())
    for (const auto& c : l.diagnoses.front().ranked)
      std::printf("  %-12s z %+.1f uniq %.2f%s\n", c.effect.c_str(), c.z_robust, c.uniqueness, c.significant ? " significant" : "");
  for (const auto& t : l.trials) std::printf("  + %-12s %s\n", t.effect.c_str(), t.why.c_str());
  if (!l.eg_unsettled.empty()) std::printf("  %s\n", l.eg_unsettled.c_str());
  return l;
}

std::vector<double> BaseTruthWith(const std::vector<double>& effect_params) {
  const auto p = TruthParams();
  std::vector<double> v{p.m, p.Jz, p.cv, p.ch, p.lv, p.is};
  v.insert(v.end(), effect_params.begin(), effect_params.end());
  return v;
}

double EgTruth() {
  const auto p = TruthParams();
  return model::SelfSteerGradient(p, kWheelbase);
}

// Catches: a ladder that judges effects by held-out RMSE alone and so keeps an EG that a body
// roll biases by its size (the bank absorbs it), or one that adds a member of the steady-state
// group on RMSE order rather than on evidence. Roll 5 deg/g; EG within 1 %.
TEST(EgRelevantRule, BodyRollTheBankAbsorbsIsAddedAndEgRecovered) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"roll"});
  const double k = 5 * M_PI / 180 / 9.81;
  for (uint64_t seed : {401u}) {
    const std::vector<double> truth = BaseTruthWith({k});
    const auto train = SyntheticTwoOutputSegments(spec, truth, 24, 120, kNoiseA, kNoiseR, seed);
    const auto valid = SyntheticTwoOutputSegments(spec, truth, 8, 120, kNoiseA, kNoiseR, seed + 100);
    const discover::Ladder l = Climb(train, valid, {"speed_scale", "roll", "gyro_scale", "accel_scale"}, 0.01, 2);
    ASSERT_EQ(l.rungs.size(), 2u) << l.stop_reason;  // then nothing more: the group's others refitted on it move nothing
    EXPECT_EQ(l.rungs[1].added, "roll");
    const auto& fit = l.rungs[1].fit;
    EXPECT_LT(std::abs(fit.eg_rad_per_mps2 / EgTruth() - 1), 0.01) << fit.eg_deg_per_g;
    EXPECT_GT(std::abs(l.rungs[0].fit.eg_rad_per_mps2 / EgTruth() - 1), 0.03) << "the bank absorbed the roll";
    EXPECT_TRUE(l.eg_unsettled.empty()) << l.eg_unsettled;
    EXPECT_TRUE(l.eg_unsettled_effects.empty());
  }
}

// Catches: an EG-relevant rule that adds effects on clean data, and an "unsettled" verdict that
// fires without cause.
TEST(EgRelevantRule, CleanDataAddsNothingAndEgIsSettled) {
  for (uint64_t seed : {411u}) {
    const auto train = SyntheticTwoOutputSegments(model::ModelSpec{}, BaseTruthWith({}), 24, 120, kNoiseA, kNoiseR, seed);
    const auto valid = SyntheticTwoOutputSegments(model::ModelSpec{}, BaseTruthWith({}), 8, 120, kNoiseA, kNoiseR, seed + 100);
    const discover::Ladder l = Climb(train, valid, {"speed_scale", "roll", "gyro_scale", "accel_scale"});
    EXPECT_EQ(l.rungs.size(), 1u) << l.rungs.back().added;
    EXPECT_TRUE(l.eg_unsettled.empty()) << l.eg_unsettled;
  }
}

// Catches: a refit that moves EG by its size and is not added (here: the rule made unreachable)
// passing without a word: EG is reported unsettled, naming the effect.
TEST(EgRelevantRule, ACandidateThatMovesEgButIsNotAddedLeavesEgUnsettled) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"roll"});
  const double k = 5 * M_PI / 180 / 9.81;
  const auto train = SyntheticTwoOutputSegments(spec, BaseTruthWith({k}), 24, 120, kNoiseA, kNoiseR, 401);
  const auto valid = SyntheticTwoOutputSegments(spec, BaseTruthWith({k}), 8, 120, kNoiseA, kNoiseR, 501);
  const discover::Ladder l = Climb(train, valid, {"roll"}, /*eg_relevant_min_improvement=*/1.0);  // neither rule can add
  ASSERT_EQ(l.rungs.size(), 1u);
  EXPECT_NE(l.eg_unsettled.find("roll"), std::string::npos) << l.eg_unsettled;
  EXPECT_EQ(l.eg_unsettled_effects, std::vector<std::string>{"roll"});  // what --apply writes as model.alternatives
}

// Catches: "EG not settled" raised by a refit the held-out data reject (on a real handling-track set,
// gyro_delay and steer_delay moved EG by -44 % and -48 % while raising the held-out a_y by 68 % and
// 88 %). The rule on one trial of the final rung: moving EG 40 % (10 sigma) with the held-out
// errors flat unsettles EG; the same move with the held-out a_y or yaw rate 5 % worse does not.
TEST(EgRelevantRule, ARefitTheHeldOutDataRejectDoesNotUnsettleEg) {
  const discover::LadderOptions o;
  discover::Trial t{.step = 2, .effect = "gyro_delay", .accepted = false, .held_out_before = 0.32, .held_out_after = 0.321,
                    .yaw_before = 0.0025, .yaw_after = 0.0025, .delta_bic = 10, .eg_shift_rel = -0.40, .eg_shift_sigma = -10};
  EXPECT_TRUE(discover::LeavesEgUnsettled(t, 2, o));
  discover::Trial worse_a = t;
  worse_a.held_out_after = 1.05 * t.held_out_before;
  EXPECT_FALSE(discover::LeavesEgUnsettled(worse_a, 2, o));
  discover::Trial worse_r = t;
  worse_r.yaw_after = 1.05 * t.yaw_before;
  EXPECT_FALSE(discover::LeavesEgUnsettled(worse_r, 2, o));
  discover::Trial a_only = worse_r;
  a_only.yaw_before = a_only.yaw_after = -1;  // a_y alone: no yaw-rate error to judge
  EXPECT_TRUE(discover::LeavesEgUnsettled(a_only, 2, o));
}

}  // namespace
}  // namespace ndsid::testing
