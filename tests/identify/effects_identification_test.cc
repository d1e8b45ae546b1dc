// Hidden effects in synthetic data: the base model's fit is biased and its residual exceeds the
// noise; adding the right effect recovers its parameter, EG and the noise floor.
#include <gtest/gtest.h>

#include "ndsid/config/config.h"
#include "ndsid/identify/identifier.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

using ndsid::testing::kWheelbase;
using ndsid::testing::Pointers;
using ndsid::testing::SyntheticSegmentsWithEffects;
using ndsid::testing::TruthParams;

config::IdentificationConfig Cfg() { return ndsid::testing::DefaultIdentificationConfig(); }

struct Case {
  const char* effect;
  double truth;
  double tolerance;         // on the recovered parameter
  double base_rmse_ratio;   // the base model's validation RMSE exceeds the noise by this factor
};

class HiddenEffect : public ::testing::TestWithParam<Case> {};

// Catches: an effect the identifier cannot recover from the data it should be identifiable
// from, or one whose absence does not show in the base model's residual.
TEST_P(HiddenEffect, BaseModelFailsAndAddingTheEffectRecoversIt) {
  const Case c = GetParam();
  const model::ModelSpec spec = model::ModelSpec::FromNames({c.effect});
  std::vector<double> truth = {1900, 2700, 75000, 120000, 1.15, 14.8, c.truth};
  constexpr double kNoise = 0.05;
  const auto train = SyntheticSegmentsWithEffects(spec, truth, 30, 60, kNoise, 11);
  const auto valid = SyntheticSegmentsWithEffects(spec, truth, 8, 60, kNoise, 12);
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);

  const Identifier base(Cfg(), kWheelbase);
  const IdentificationResult rb = base.Identify(Pointers(train), Pointers(valid));
  ASSERT_TRUE(rb.valid) << rb.reason;
  std::printf("%s: base model validation RMSE %.5f (noise %.3f)\n", c.effect, rb.rmse_validation_mps2, kNoise);
  EXPECT_GT(rb.rmse_validation_mps2, c.base_rmse_ratio * kNoise) << c.effect << ": the base model should visibly fail";

  const Identifier with(Cfg(), kWheelbase, spec);
  const IdentificationResult re = with.Identify(Pointers(train), Pointers(valid));
  ASSERT_TRUE(re.valid) << re.reason;
  ASSERT_EQ(re.effect_params.size(), 1u);
  EXPECT_NEAR(re.effect_params[0].value, c.truth, c.tolerance) << c.effect;
  EXPECT_NEAR(re.rmse_validation_mps2, kNoise, 0.1 * kNoise) << c.effect;
  EXPECT_NEAR(re.eg_rad_per_mps2, eg_true, 0.01 * eg_true) << c.effect;
}

INSTANTIATE_TEST_SUITE_P(Effects, HiddenEffect,
                         // The lever arm is largely absorbed by lv/Jz on smooth steering (a_y at a point
                         // x_s ahead of the CG is what a shifted CG would give): it must still be
                         // recovered when modelled, but the base model barely shows it. A steering
                         // delay is partly absorbed too (Jz, lv and the tyres on their bounds): at the
                         // base model's exact optimum an 80 ms delay raises the RMSE by 13 % (about 40
                         // standard errors of an RMSE over 8 validation minutes of white noise).
                         ::testing::Values(Case{"steer_offset", 0.026, 0.002, 1.15}, Case{"accel_bias", 0.1, 0.01, 1.15},
                                           Case{"lever_arm", 0.8, 0.08, 1.0}, Case{"steer_delay", 0.08, 0.008, 1.10}),
                         [](const auto& info) { return std::string(info.param.effect); });

}  // namespace
}  // namespace ndsid::identify

namespace ndsid::identify {
namespace {

// Catches: a formula hypothesis from the configuration that Ceres cannot fit (derivatives,
// parameter layout, bounds): a cubic accelerometer gain a_meas = a_y + k3 a_y^3 hidden in the
// data is recovered through the formula. (On this mild synthetic driving the base model absorbs
// most of an odd cubic term into EG, physics.md §4, so no RMSE comparison is asserted.)
TEST(FormulaEffect, CubicGainStatedInYamlIsRecovered) {
  const config::Config c = config::ParseConfig(std::string(ndsid::testing::kMinimalVehicleYaml) + R"(model:
  effects: [cubic_gain]
  formulas:
    cubic_gain:
      a_y_meas: "a_y + k3*a_y^3"
      parameters: {k3: {min: -0.05, max: 0.05, unit: "s^4/m^2"}}
)", "t.yaml");
  const model::ModelSpec spec = model::ModelSpec::FromNames(c.model_effects, model::EffectLibrary(c.model_formulas));
  const std::vector<double> truth = {1900, 2700, 75000, 120000, 1.15, 14.8, 0.01};
  const auto train = testing::SyntheticSegmentsWithEffects(spec, truth, 20, 60, 0.05, 21);
  const auto valid = testing::SyntheticSegmentsWithEffects(spec, truth, 6, 60, 0.05, 22);
  const Identifier with(Cfg(), testing::kWheelbase, spec);
  const IdentificationResult r = with.Identify(testing::Pointers(train), testing::Pointers(valid));
  ASSERT_TRUE(r.valid) << r.reason;
  ASSERT_EQ(r.effect_params.size(), 1u);
  EXPECT_EQ(r.effect_params[0].name, "k3");
  EXPECT_NEAR(r.effect_params[0].value, 0.01, 0.001);
  EXPECT_NEAR(r.rmse_validation_mps2, 0.05, 0.005);
  const double eg_true = model::SelfSteerGradient(TruthParams(), testing::kWheelbase);
  EXPECT_NEAR(r.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
}

// Catches: a formula with two targets sharing its parameter, reading the speed and the axles'
// slip angles, that Ceres cannot fit. Both axles stiffen with speed, c(v) = c (1 + k (v/30)^2),
// stated as a slip-angle term per axle; recovered on several seeds, with EG (at low speed, the
// base parameters) within 1 %; the base model without it absorbs the stiffening into EG.
TEST(FormulaEffect, StiffnessRisingWithSpeedOnBothAxlesIsRecovered) {
  const config::Config c = config::ParseConfig(std::string(ndsid::testing::kMinimalVehicleYaml) + R"(model:
  effects: [stiff_speed]
  formulas:
    stiff_speed:
      alpha_v: "k*(v/30)^2*alpha_v"
      alpha_h: "k*(v/30)^2*alpha_h"
      parameters: {k: {min: -0.5, max: 0.5}}
)", "t.yaml");
  const model::EffectLibrary library(c.model_formulas);
  const model::ModelSpec spec = model::ModelSpec::FromNames(c.model_effects, library);
  const model::ModelSpec base = model::ModelSpec::FromNames({}, library);
  const double eg_true = model::SelfSteerGradient(TruthParams(), testing::kWheelbase);
  for (const auto& [k_true, seed] : {std::pair{0.25, 31}, std::pair{-0.2, 33}, std::pair{0.15, 35}}) {
    const std::vector<double> truth = {1900, 2700, 75000, 120000, 1.15, 14.8, k_true};
    const auto train = testing::SyntheticSegmentsWithEffects(spec, truth, 20, 60, 0.05, seed);
    const auto valid = testing::SyntheticSegmentsWithEffects(spec, truth, 6, 60, 0.05, seed + 1);
    const IdentificationResult r = Identifier(Cfg(), testing::kWheelbase, spec).Identify(testing::Pointers(train), testing::Pointers(valid));
    ASSERT_TRUE(r.valid) << r.reason;
    ASSERT_EQ(r.effect_params.size(), 1u);
    EXPECT_NEAR(r.effect_params[0].value, k_true, 0.02) << seed;
    EXPECT_NEAR(r.rmse_validation_mps2, 0.05, 0.005) << seed;
    EXPECT_NEAR(r.eg_rad_per_mps2, eg_true, 0.01 * std::abs(eg_true)) << seed;
    const IdentificationResult b = Identifier(Cfg(), testing::kWheelbase, base).Identify(testing::Pointers(train), testing::Pointers(valid));
    EXPECT_GT(std::abs(b.eg_rad_per_mps2 / eg_true - 1), 0.03) << seed;  // absorbed, it moves EG
  }
}

}  // namespace
}  // namespace ndsid::identify

namespace ndsid::identify {
namespace {

// Catches: a prior (model.priors) that does not act, or that the covariance ignores. Synthetic
// data with a hidden 5 deg/g roll gradient, whose steady part the data cannot tell from EG
// (physics.md §4). A prior of the true value +- 10 % must pull the estimate to it, bring EG
// within 1 % of the truth, and give the roll gradient a standard error no larger than the
// prior's sd (the data add little); a prior at a wrong value must move the estimate towards it.
TEST(Priors, PriorResolvesAConfoundedEffectAndEntersTheCovariance) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"roll"});
  const double k_true = 5 * M_PI / 180 / 9.81;
  const std::vector<double> truth = {1900, 2700, 75000, 120000, 1.15, 14.8, k_true};
  const auto train = ndsid::testing::SyntheticSegmentsWithEffects(spec, truth, 20, 60, 0.05, 21);
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  auto fit_with_prior = [&](double value, double sd) {
    config::IdentificationConfig cfg = Cfg();
    cfg.priors.push_back({"roll_gradient_rad_per_mps2", value, sd, "test"});
    const Identifier id(cfg, kWheelbase, spec);
    const IdentificationResult r = id.Identify(Pointers(train), {});
    EXPECT_TRUE(r.valid) << r.reason;
    return r;
  };
  const IdentificationResult right = fit_with_prior(k_true, 0.1 * k_true);
  ASSERT_EQ(right.effect_params.size(), 1u);
  std::printf("prior at truth: k %.5f ± %.5f (truth %.5f), EG %.6f (truth %.6f)\n", right.effect_params[0].value,
              right.effect_params[0].se, k_true, right.eg_rad_per_mps2, eg_true);
  EXPECT_NEAR(right.effect_params[0].value, k_true, 0.1 * k_true);
  EXPECT_LE(right.effect_params[0].se, 0.1 * k_true * 1.01);
  EXPECT_GT(right.effect_params[0].se, 0.0);
  EXPECT_NEAR(right.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
  const IdentificationResult wrong = fit_with_prior(2 * k_true, 0.05 * k_true);
  std::printf("prior at 2x truth: k %.5f, EG %.6f\n", wrong.effect_params[0].value, wrong.eg_rad_per_mps2);
  // At least a third of the way from the estimate with the right prior to the wrong prior's value.
  const double k_right = right.effect_params[0].value;
  EXPECT_GT(wrong.effect_params[0].value - k_right, (2 * k_true - k_right) / 3);
}


// Catches: a prior on EG itself (model.priors eg_deg_per_g, a fleet group's EG) that does not
// act on the base parameters, or that the covariance ignores. The same confounded data as above
// (a roll gradient the data cannot tell from EG's steady part), no prior on the roll gradient. A
// prior on EG at the truth, as sure as the data, must give EG the sigma of the two combined
// (1/s^2 = 1/s_data^2 + 1/s_prior^2, exact for a linearised fit; here within 15 % with the
// autocorrelation and halves terms); a prior 5 % off must pull EG half of the way to it (the two
// equally sure: 35-65 %).
TEST(Priors, AnEgPriorPullsTheBaseParametersAndCombinesWithTheDatasSigma) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"roll"});
  const double k_true = 5 * M_PI / 180 / 9.81;
  const std::vector<double> truth = {1900, 2700, 75000, 120000, 1.15, 14.8, k_true};
  const double eg_true = model::EgToDegPerG(model::SelfSteerGradient(TruthParams(), kWheelbase));
  for (const uint64_t seed : {21u, 23u}) {
    const auto train = ndsid::testing::SyntheticSegmentsWithEffects(spec, truth, 20, 60, 0.05, seed);
    auto fit = [&](double value, double sd) {
      config::IdentificationConfig cfg = Cfg();
      if (sd > 0) cfg.priors.push_back({config::kEgPriorName, value, sd, "test"});
      const IdentificationResult r = Identifier(cfg, kWheelbase, spec).Identify(Pointers(train), {});
      EXPECT_TRUE(r.valid) << r.reason;
      return r;
    };
    const IdentificationResult alone = fit(0, 0);
    const double s_prior = alone.eg_se_deg_per_g;
    const IdentificationResult right = fit(eg_true, s_prior);
    const double s_combined = 1 / std::sqrt(1 / (alone.eg_se_deg_per_g * alone.eg_se_deg_per_g) + 1 / (s_prior * s_prior));
    std::printf("seed %d: alone EG %.4f +- %.4f; EG prior %.4f +- %.4f: EG %.4f +- %.4f (combined %.4f)\n", static_cast<int>(seed),
                alone.eg_deg_per_g, alone.eg_se_deg_per_g, eg_true, s_prior, right.eg_deg_per_g, right.eg_se_deg_per_g, s_combined);
    EXPECT_NEAR(right.eg_deg_per_g, eg_true, 2 * s_combined) << seed;
    EXPECT_NEAR(right.eg_se_deg_per_g, s_combined, 0.15 * s_combined) << seed;
    const IdentificationResult wrong = fit(1.05 * eg_true, s_prior);
    const double pulled = (wrong.eg_deg_per_g - alone.eg_deg_per_g) / (1.05 * eg_true - alone.eg_deg_per_g);
    std::printf("seed %d: a prior 5 %% off pulls EG %.0f %% of the way\n", static_cast<int>(seed), 100 * pulled);
    EXPECT_GT(pulled, 0.35) << seed;
    EXPECT_LT(pulled, 0.65) << seed;
  }
}

}  // namespace
}  // namespace ndsid::identify
