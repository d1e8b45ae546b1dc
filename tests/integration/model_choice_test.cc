// Model choice end to end (docs/monitoring.md, "model_choice"): simulated drives whose
// accelerometer or gyro reads a few percent off. The two-output fit alone splits the scale
// disagreement between a_y and the yaw rate and gives an EG with a sigma far smaller than the
// spread over the sensor it could blame; the pipeline refits the window with the disagreement
// attributed to each sensor, widens the published sigma to cover the spread (or fails
// model_choice), and lists the alternatives. Clean drives: nothing refitted, no check added.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "ndsid/common/json_codec.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "../identify/synthetic_segments.h"
#include "sim_harness.h"

namespace ndsid::testing {
namespace {

const pipeline::ModelAlternative* Alternative(const pipeline::Estimate& e, const std::string& name) {
  for (const pipeline::ModelAlternative& a : e.model_choice.alternatives)
    if (a.name == name) return &a;
  return nullptr;
}

constexpr double kHours = 0.5;
const ReplayTweaks kTwoOutputs{.identify_every_s = 0, .mass_schedule_kg = {}, .yaw_rate_output = true};

// The published estimate with a hidden sensor scale: either valid with sigma covering the truth,
// or not valid because model_choice failed; the attribution to the scaled sensor near the truth.
void ExpectCovered(const std::string& effect, const std::string& scaled, uint64_t seed) {
  SimulatedRun run = SimulateAndReplay("model_choice_" + scaled + std::to_string(seed), seed, kHours, {effect},
                                       {"road_bank", "gyro_offset"}, kTwoOutputs);
  const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
  const double truth = model::EgToDegPerG(run.eg_truth);
  ASSERT_TRUE(e.model_choice.judged) << effect << " " << seed << "\n" << CheckList(e);
  const adequacy::Check* c = FindCheck(e, "model_choice");
  ASSERT_NE(c, nullptr) << CheckList(e);
  std::printf("%s seed %llu: EG %.3f +- %.3f deg/g (truth %.3f), %s; %s\n", effect.c_str(), static_cast<unsigned long long>(seed),
              e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g, truth, e.fit.valid ? "valid" : "not valid", c->message.c_str());
  if (e.fit.valid) {
    EXPECT_LE(std::abs(e.fit.eg_deg_per_g - truth), 2 * e.fit.eg_se_deg_per_g) << effect << " " << seed << "\n" << c->message;
  } else {
    EXPECT_EQ(c->verdict, adequacy::Verdict::kFailed) << e.fit.reason;
  }
  const pipeline::ModelAlternative* a = Alternative(e, scaled);
  ASSERT_NE(a, nullptr) << c->message;
  ASSERT_TRUE(a->fitted) << a->reason;
  EXPECT_FALSE(a->ruled_out) << a->ruled_out_why;
  EXPECT_LT(std::abs(a->eg_deg_per_g / truth - 1), 0.01) << effect << " " << seed << ": " << c->message;
  // The bus has a_x: the speed scale is decided (consistent with 0), not an alternative.
  EXPECT_EQ(Alternative(e, "speed_scale"), nullptr) << c->message;
}

// Catches: an accelerometer scale error published with a sigma that excludes the truth.
TEST(ModelChoice, AnAccelerometerScaleIsCoveredBySigma) {
  for (uint64_t seed : {301, 302}) ExpectCovered("accel_scale_pct=3", "accel_scale", seed);
  for (uint64_t seed : {303, 304}) ExpectCovered("accel_scale_pct=-3", "accel_scale", seed);
}

// Catches: a gyro scale error refitted but published with a sigma that excludes the truth.
TEST(ModelChoice, AGyroScaleIsCoveredBySigmaWhereRefitted) {
  ExpectCovered("gyro_scale_pct=3", "gyro_scale", 306);
}

// Catches: a gyro scale that the kinematic gain misses published as valid and a few percent off.
// The model-free gain a_y/(v r) reads about +1.4 % on clean simulated drives, which offsets a +3 %
// gyro scale towards 1 (on seeds 305 and 309 it is not significant); the rear wheels measure the
// gyro's scale, rule out the fit as identified and every attribution but the gyro's, and that
// refit (free with their prior, or held at their value: whichever predicts the held-out a_y
// better) is published: EG within 1 % of the truth and within 2 sigma.
TEST(ModelChoice, TheRearWheelsDecideAGyroScale) {
  for (const auto& [effect, seed] : {std::pair{"gyro_scale_pct=3", 305}, {"gyro_scale_pct=3", 309}, {"gyro_scale_pct=-3", 310}}) {
    SimulatedRun run = SimulateAndReplay("model_choice_wheels_" + std::to_string(seed), seed, kHours, {effect},
                                         {"road_bank", "gyro_offset"}, kTwoOutputs);
    const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
    const double truth = model::EgToDegPerG(run.eg_truth);
    const adequacy::Check* c = FindCheck(e, "model_choice");
    ASSERT_NE(c, nullptr) << effect << " " << seed << "\n" << CheckList(e);
    std::printf("%s seed %d: EG %.3f +- %.3f deg/g (truth %.3f), %s; %s\n", effect, seed, e.fit.eg_deg_per_g,
                e.fit.eg_se_deg_per_g, truth, e.fit.valid ? "valid" : "not valid", c->message.c_str());
    ASSERT_TRUE(e.model_choice.wheel_yaw.available) << e.model_choice.wheel_yaw.note;
    EXPECT_FALSE(e.model_choice.fit_ruled_out_why.empty()) << c->message;
    EXPECT_TRUE(e.model_choice.published.starts_with("gyro_scale")) << c->message;  // fitted, or held at the wheels' value
    const pipeline::ModelAlternative* accel = Alternative(e, "accel_scale");
    ASSERT_NE(accel, nullptr) << c->message;
    EXPECT_TRUE(accel->ruled_out) << c->message;
    ASSERT_TRUE(e.fit.valid) << e.fit.reason;
    EXPECT_LT(std::abs(e.fit.eg_deg_per_g / truth - 1), 0.01) << c->message;
    EXPECT_LE(std::abs(e.fit.eg_deg_per_g - truth), 2 * e.fit.eg_se_deg_per_g) << c->message;
  }
}

// Catches: the rear wheels blaming the gyro for an accelerometer's scale.
TEST(ModelChoice, TheRearWheelsClearTheGyroOfAnAccelerometerScale) {
  SimulatedRun run = SimulateAndReplay("model_choice_wheels_accel", 311, kHours, {"accel_scale_pct=3"},
                                       {"road_bank", "gyro_offset"}, kTwoOutputs);
  const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
  const adequacy::Check* c = FindCheck(e, "model_choice");
  ASSERT_NE(c, nullptr) << CheckList(e);
  EXPECT_TRUE(e.model_choice.fit_ruled_out_why.empty()) << c->message;
  const pipeline::ModelAlternative* gyro = Alternative(e, "gyro_scale");
  ASSERT_NE(gyro, nullptr) << c->message;
  EXPECT_TRUE(gyro->ruled_out) << c->message;
  EXPECT_NE(gyro->ruled_out_why.find("rear wheels"), std::string::npos) << gyro->ruled_out_why;
}

// Catches: refits (and a changed sigma) on clean data, where a_y and v r agree in scale.
TEST(ModelChoice, CleanDataAreNotRefitted) {
  for (uint64_t seed : {307, 308}) {
    SimulatedRun run = SimulateAndReplay("model_choice_clean_" + std::to_string(seed), seed, kHours, {},
                                         {"road_bank", "gyro_offset"}, kTwoOutputs);
    const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
    ASSERT_TRUE(e.fit.valid) << e.fit.reason << "\n" << CheckList(e);
    EXPECT_FALSE(e.model_choice.judged) << FindCheck(e, "kinematics")->message;
    EXPECT_TRUE(e.model_choice.alternatives.empty());
    EXPECT_EQ(FindCheck(e, "model_choice"), nullptr);
    EXPECT_FALSE(pipeline::ScaleDisagreement(e.fit, e.plausibility));
  }
}

// Catches: a model choice the ladder could not make (an effect that moves EG, listed in
// model.alternatives by `diagnose --apply`) published with a sigma that excludes the truth. Tyres
// that saturate (mu 0.8) inside the gate's 4 m/s^2, a model without it: a_y and v r agree in scale,
// so no sensor is refitted, and the linear fit is 1-3 % off the linear truth, 4-5 of its sigma.
// The refit with tyre_saturation stands (it lowers the held-out errors), near the truth, and the
// published sigma covers the truth or model_choice fails.
TEST(ModelChoice, AConfiguredAlternativeThatMovesEgWidensSigma) {
  for (uint64_t seed : {312, 313}) {
    ReplayTweaks tweaks = kTwoOutputs;
    tweaks.alternatives = {"tyre_saturation"};
    SimulatedRun run = SimulateAndReplay("model_choice_tyre_" + std::to_string(seed), seed, kHours, {"tyre_mu=0.8"},
                                         {"road_bank", "gyro_offset"}, tweaks);
    const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
    const double truth = model::EgToDegPerG(run.eg_truth);
    const adequacy::Check* c = FindCheck(e, "model_choice");
    ASSERT_NE(c, nullptr) << CheckList(e);
    std::printf("tyre_mu 0.8 seed %llu: EG %.3f +- %.3f deg/g (truth %.3f), %s; %s\n", static_cast<unsigned long long>(seed),
                e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g, truth, e.fit.valid ? "valid" : "not valid", c->message.c_str());
    ASSERT_EQ(e.model_choice.alternatives.size(), 1u) << c->message;  // no scale disagreement: the alternative alone
    const pipeline::ModelAlternative& tyre = e.model_choice.alternatives.front();
    ASSERT_TRUE(tyre.fitted) << tyre.reason;
    EXPECT_EQ(tyre.name, "tyre_saturation");
    EXPECT_TRUE(tyre.configured);
    EXPECT_EQ(tyre.parameter, "tyre_inv_mu_sq [-]");
    EXPECT_FALSE(tyre.ruled_out) << tyre.ruled_out_why;
    EXPECT_LT(std::abs(tyre.eg_deg_per_g / truth - 1), 0.01) << c->message;
    EXPECT_NEAR(tyre.scale, 1 / (0.8 * 0.8), 0.25 / (0.8 * 0.8)) << c->message;  // 1/mu^2 within 25 %
    // The fit alone (sigma before the widening) excludes the truth: without the alternative the
    // published estimate would have been wrong.
    const double spread = std::abs(tyre.eg_deg_per_g - e.fit.eg_deg_per_g);
    const double sigma_alone = std::sqrt(std::max(0.0, e.fit.eg_se_deg_per_g * e.fit.eg_se_deg_per_g - spread * spread));
    EXPECT_GT(std::abs(e.fit.eg_deg_per_g - truth), 3 * sigma_alone) << c->message;
    if (e.fit.valid) {
      EXPECT_LE(std::abs(e.fit.eg_deg_per_g - truth), 2 * e.fit.eg_se_deg_per_g) << c->message;
    } else {
      EXPECT_EQ(c->verdict, adequacy::Verdict::kFailed) << e.fit.reason;
    }
    // The alternatives travel in estimate.json.
    const nlohmann::json doc = pipeline::EstimateToJson(e);
    const pipeline::Estimate back = pipeline::EstimateFromJson(JsonIn(doc, "estimate"));
    ASSERT_EQ(back.model_choice.alternatives.size(), 1u);
    EXPECT_TRUE(back.model_choice.alternatives.front().configured);
    EXPECT_EQ(back.model_choice.alternatives.front().parameter, tyre.parameter);
  }
}

// Catches: a tyre that saturates inside the gate published with a sigma that excludes the truth
// when nobody listed the effect (model.watch, by default tyre_saturation): the linear fit's
// residual stays near its floor while EG is a few per cent high; the score test at the fit finds
// the saturation, the refit stands near the truth and the published sigma covers the truth or
// model_choice fails. Other seeds and grips than the configured case above; a_y alone as well.
TEST(ModelChoice, AWatchedEffectTheScoreTestFindsWidensSigma) {
  struct Case {
    uint64_t seed;
    double mu;
    bool two_outputs;
  };
  for (const Case& k : {Case{314, 0.8, true}, Case{315, 0.9, true}, Case{316, 0.8, false}}) {
    ReplayTweaks tweaks;
    tweaks.yaw_rate_output = k.two_outputs;
    SimulatedRun run = SimulateAndReplay("model_choice_watch_" + std::to_string(k.seed), k.seed, kHours,
                                         {"tyre_mu=" + std::to_string(k.mu)}, {"road_bank", "gyro_offset"}, tweaks);
    const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
    const double truth = model::EgToDegPerG(run.eg_truth);
    const adequacy::Check* c = FindCheck(e, "model_choice");
    ASSERT_NE(c, nullptr) << "seed " << k.seed << ": the score test did not find the saturation\n" << CheckList(e);
    std::printf("tyre_mu %.1f seed %llu (%s): EG %.3f +- %.3f deg/g (truth %.3f), %s; %s\n", k.mu,
                static_cast<unsigned long long>(k.seed), k.two_outputs ? "two outputs" : "a_y", e.fit.eg_deg_per_g,
                e.fit.eg_se_deg_per_g, truth, e.fit.valid ? "valid" : "not valid", c->message.c_str());
    const pipeline::ModelAlternative* tyre = Alternative(e, "tyre_saturation");
    ASSERT_NE(tyre, nullptr) << c->message;
    EXPECT_NE(tyre->evidence.find("score test"), std::string::npos) << tyre->evidence;
    EXPECT_NE(c->message.find("model.watch"), std::string::npos) << c->message;
    ASSERT_TRUE(tyre->fitted) << tyre->reason;
    EXPECT_FALSE(tyre->ruled_out) << tyre->ruled_out_why;
    EXPECT_LT(std::abs(tyre->eg_deg_per_g / truth - 1), 0.01) << c->message;
    if (e.fit.valid) {
      EXPECT_LE(std::abs(e.fit.eg_deg_per_g - truth), 2 * e.fit.eg_se_deg_per_g) << c->message;
    } else {
      EXPECT_EQ(c->verdict, adequacy::Verdict::kFailed) << e.fit.reason;
    }
    // The evidence travels in estimate.json.
    const pipeline::Estimate back = pipeline::EstimateFromJson(JsonIn(pipeline::EstimateToJson(e), "estimate"));
    const pipeline::ModelAlternative* read = Alternative(back, "tyre_saturation");
    ASSERT_NE(read, nullptr);
    EXPECT_EQ(read->evidence, tyre->evidence);
  }
}

// Catches: the incremental updates between two score tests of model.watch publishing the linear
// fit's narrow sigma again. A periodic replay (1.5 h, a fit every 5 min of data, incremental): the test
// runs at the first fit and where the gated time has doubled since the last one; the updates
// between carry what the last test found (its EG shift, not refitted).
TEST(ModelChoice, AWatchedEffectFoundIsCarriedToTheIncrementalUpdatesBetweenTests) {
  ReplayTweaks tweaks;
  tweaks.identify_every_s = 300;
  SimulatedRun run = SimulateAndReplay("model_choice_watch_periodic", 316, 1.5, {"tyre_mu=0.8"}, {"road_bank", "gyro_offset"}, tweaks);
  bool found_before = false;
  int carried = 0;
  for (const pipeline::Estimate& e : run.pipeline->history()) {
    const pipeline::ModelAlternative* tyre = Alternative(e, "tyre_saturation");
    std::printf("%.2f gated h, %s: EG %.3f +- %.3f deg/g, tyre_saturation %s\n", e.gated_hours, e.fit.update.c_str(), e.fit.eg_deg_per_g,
                e.fit.eg_se_deg_per_g, tyre ? tyre->evidence.c_str() : "-");
    if (found_before && !e.model_choice.watch_tested) {
      ASSERT_NE(tyre, nullptr) << "an update after the test found the saturation does not carry it";
      EXPECT_NE(tyre->evidence.find("at the last full-window or exact fit"), std::string::npos) << tyre->evidence;
      ++carried;
    }
    if (e.model_choice.watch_tested) found_before = tyre != nullptr;
  }
  EXPECT_GT(carried, 0) << "no update between two tests after the saturation was found";
}

// Catches: a watched effect that is not in the library accepted (it would fail at the first fit),
// and one the model already has, lists as an alternative or cannot take tested anyway.
TEST(ModelChoice, WatchedEffectsAreCheckedAndSkippedWhereTheModelHasThem) {
  const model::EffectLibrary& lib = model::EffectLibrary::Builtin();
  EXPECT_NO_THROW(pipeline::CheckWatched({"tyre_saturation", "lever_arm"}, lib));
  EXPECT_THROW(pipeline::CheckWatched({"no_such_effect"}, lib), ConfigError);
  EXPECT_THROW(pipeline::CheckWatched({"lever_arm", "lever_arm"}, lib), ConfigError);
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset", "tyre_saturation"}, lib);
  EXPECT_EQ(pipeline::WatchedToTest({"tyre_saturation", "lever_arm", "relaxation", "gyro_offset_per_drive"}, spec, {"relaxation"}),
            std::vector<std::string>{"lever_arm"});
}

// Catches: configured alternatives that clean data cannot tell from their absence ruining the
// estimate, and a formula effect (model.formulas) not found as an alternative: the lever arm and
// an accelerometer gain stated as a formula, refitted, stand and move EG within its sigma.
TEST(ModelChoice, AConfiguredAlternativeOnCleanDataLeavesTheEstimateValid) {
  ReplayTweaks tweaks = kTwoOutputs;
  tweaks.alternatives = {"lever_arm", "a_y_gain"};
  tweaks.formulas = config::ParseConfig(std::string(kMinimalVehicleYaml) + R"yaml(model:
  formulas:
    a_y_gain:
      a_y_meas: "a_y*(1 + s)"
      parameters:
        s: {min: -0.2, max: 0.2}
)yaml", "formulas.yaml").model_formulas;
  SimulatedRun run = SimulateAndReplay("model_choice_lever_clean", 307, kHours, {}, {"road_bank", "gyro_offset"}, tweaks);
  const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
  const double truth = model::EgToDegPerG(run.eg_truth);
  const adequacy::Check* c = FindCheck(e, "model_choice");
  ASSERT_NE(c, nullptr) << CheckList(e);
  std::printf("clean + lever_arm: EG %.3f +- %.3f deg/g (truth %.3f), %s; %s\n", e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g, truth,
              e.fit.valid ? "valid" : "not valid", c->message.c_str());
  ASSERT_TRUE(e.fit.valid) << e.fit.reason;
  const pipeline::ModelAlternative* lever = Alternative(e, "lever_arm");
  ASSERT_NE(lever, nullptr) << c->message;
  ASSERT_TRUE(lever->fitted) << lever->reason;
  EXPECT_FALSE(lever->ruled_out) << lever->ruled_out_why;
  EXPECT_LE(std::abs(e.fit.eg_deg_per_g - truth), 3 * e.fit.eg_se_deg_per_g) << c->message;
  EXPECT_LT(std::abs(lever->eg_deg_per_g - e.fit.eg_deg_per_g), e.fit.eg_se_deg_per_g) << c->message;
  const pipeline::ModelAlternative* gain = Alternative(e, "a_y_gain");
  ASSERT_NE(gain, nullptr) << c->message;
  ASSERT_TRUE(gain->fitted) << gain->reason;
  EXPECT_EQ(gain->parameter, "s [-]");
  EXPECT_LT(std::abs(gain->scale), 0.02) << c->message;  // the simulated accelerometer has no scale error
  EXPECT_LT(std::abs(gain->eg_deg_per_g / truth - 1), 0.01) << c->message;
}

// Catches: a model.alternatives list that cannot be refitted (an unknown name, an effect of the
// model already, one listed twice, one sharing a parameter with the model's) accepted at load
// and failing at every estimate instead.
TEST(ModelChoice, ConfiguredAlternativesAreCheckedAgainstTheModel) {
  const model::EffectLibrary& lib = model::EffectLibrary::Builtin();
  EXPECT_NO_THROW(pipeline::CheckAlternatives({"lever_arm", "tyre_saturation"}, {"road_bank", "gyro_offset"}, lib));
  const auto message = [&](const std::vector<std::string>& alternatives, const std::vector<std::string>& effects) {
    try {
      pipeline::CheckAlternatives(alternatives, effects, lib);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message({"lever_arm", "no_such_effect"}, {}).find("'no_such_effect' is not an effect"), std::string::npos);
  EXPECT_NE(message({"road_bank"}, {"road_bank"}).find("in model.effects already"), std::string::npos);
  EXPECT_NE(message({"roll", "roll"}, {}).find("listed twice"), std::string::npos);
  EXPECT_NE(message({"gyro_offset_per_drive"}, {"gyro_offset"}).find("share the parameter"), std::string::npos);
}

}  // namespace
}  // namespace ndsid::testing
