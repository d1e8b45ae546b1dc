// The ladder's determination rule (LadderOptions::determined_z): an effect is added only when each
// of its parameters lies more than determined_z standard errors from its neutral value.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ndsid/discover/diagnosis.h"
#include "synthetic_segments.h"

namespace ndsid::testing {
namespace {

// Catches: a ladder that adds an effect on the held-out RMSE and BIC alone, or a rule that rejects
// what it should keep. A hidden 1.5 deg steering offset (determined many times over: z ~ 100) is
// added under the default rule, with its parameter beyond 3 sigma; demanding more sigma than the
// data give rejects the same refit, says why, and leaves the model as it was. Two seeds.
TEST(DeterminationRule, AnEffectIsAddedOnlyWhenItsParameterIsDetermined) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"steer_offset"});
  for (uint64_t seed : {51u, 52u}) {
    std::vector<double> truth = TruthVector();
    truth.push_back(1.5 * M_PI / 180);
    const auto train = SyntheticSegmentsWithEffects(spec, truth, 12, 60, 0.05, seed);
    const auto valid = SyntheticSegmentsWithEffects(spec, truth, 3, 60, 0.05, seed + 100);
    auto climb = [&](double z) {
      discover::LadderOptions o;
      o.align = false;
      o.max_steps = 1;
      o.diagnosis.candidates = {"steer_offset", "accel_bias"};
      o.determined_z = z;
      return discover::ClimbErrorLadder(DefaultIdentificationConfig(), kWheelbase, {"road_bank"}, model::EffectLibrary::Builtin(),
                                        Pointers(train), Pointers(valid), o);
    };
    const discover::Ladder added = climb(3.0);
    ASSERT_EQ(added.rungs.size(), 2u) << seed;
    EXPECT_EQ(added.rungs[1].added, "steer_offset");
    const auto& p = added.rungs[1].fit.effect_params;
    const auto so = std::find_if(p.begin(), p.end(), [](const auto& e) { return e.name == "steer_offset_rad"; });
    ASSERT_NE(so, p.end());
    const double z = std::abs(so->value) / so->se;
    EXPECT_GT(z, 3.0) << seed;

    const discover::Ladder strict = climb(2.0 * z);
    EXPECT_EQ(strict.rungs.size(), 1u) << seed;
    const auto trial = std::find_if(strict.trials.begin(), strict.trials.end(), [](const auto& t) { return t.effect == "steer_offset"; });
    ASSERT_NE(trial, strict.trials.end());
    EXPECT_FALSE(trial->accepted);
    EXPECT_NE(trial->why.find("steer_offset_rad"), std::string::npos) << trial->why;
    EXPECT_NE(trial->why.find("(not determined)"), std::string::npos) << trial->why;
  }
}

// Catches: a ladder that adds an effect whose parameter the data push onto its box (the box is the
// physically plausible range; a value on its edge stands in for something else). An accelerometer
// bias of 3 m/s^2, beyond accel_bias's +-2 m/s^2: the refit lowers the held-out RMSE, yet it is
// rejected as not plausible and the model stays as it was; a bias of 1 m/s^2 inside the box is
// added. Two seeds.
TEST(PlausibilityRule, AnEffectOnItsBoundIsNotAdded) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"accel_bias"});
  for (uint64_t seed : {53u, 54u}) {
    auto climb = [&](double bias) {
      std::vector<double> truth = TruthVector();
      truth.push_back(bias);
      const auto train = SyntheticSegmentsWithEffects(spec, truth, 12, 60, 0.05, seed);
      const auto valid = SyntheticSegmentsWithEffects(spec, truth, 3, 60, 0.05, seed + 100);
      discover::LadderOptions o;
      o.align = false;
      o.max_steps = 1;
      o.diagnosis.candidates = {"accel_bias"};
      return discover::ClimbErrorLadder(DefaultIdentificationConfig(), kWheelbase, {"road_bank"}, model::EffectLibrary::Builtin(),
                                        Pointers(train), Pointers(valid), o);
    };
    const discover::Ladder inside = climb(1.0);
    ASSERT_EQ(inside.rungs.size(), 2u) << seed;
    EXPECT_EQ(inside.rungs[1].added, "accel_bias");

    const discover::Ladder beyond = climb(3.0);
    EXPECT_EQ(beyond.rungs.size(), 1u) << seed;
    const auto trial = std::find_if(beyond.trials.begin(), beyond.trials.end(), [](const auto& t) { return t.effect == "accel_bias"; });
    ASSERT_NE(trial, beyond.trials.end());
    EXPECT_FALSE(trial->accepted);
    EXPECT_LT(trial->held_out_after, trial->held_out_before) << trial->why;  // the error falls, the value is implausible
    EXPECT_NE(trial->why.find("on its bound"), std::string::npos) << trial->why;
  }
}

}  // namespace
}  // namespace ndsid::testing
