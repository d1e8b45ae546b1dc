// The two-output fit (identification.outputs [a_y, yaw_rate]): a_y and the yaw rate in one
// problem, each weighted by its own noise level; the gyro effects; the fallback to a_y alone.
// Truths are the parameters the synthetic segments were generated with (synthetic_segments.h).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <utility>

#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

using ndsid::testing::kWheelbase;
using ndsid::testing::Pointers;
using ndsid::testing::SyntheticTwoOutputSegments;
using ndsid::testing::TruthParams;
using ndsid::testing::TruthVector;

constexpr double kNoiseA = 0.05;                 // m/s^2, as the simulator's accelerometer
constexpr double kNoiseR = 0.1 * M_PI / 180.0;  // rad/s, as the simulator's gyro (0.1 deg/s)
constexpr double kDeg = M_PI / 180.0;

config::IdentificationConfig Cfg(bool yaw_rate) {
  config::IdentificationConfig c = ndsid::testing::DefaultIdentificationConfig();
  c.yaw_rate_output = yaw_rate;
  return c;
}

// Catches: a second output that is mis-weighted, mis-signed or mis-aligned (the fit would move
// away from the truth or its RMSEs off the noise), or that adds no information on EG.
TEST(TwoOutputs, RecoversEgAndParametersOnCleanDataForThreeSeeds) {
  const model::ModelSpec spec;
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  for (uint64_t seed : {31u, 32u, 33u}) {
    const auto train = SyntheticTwoOutputSegments(spec, TruthVector(), 16, 60, kNoiseA, kNoiseR, seed);
    const auto valid = SyntheticTwoOutputSegments(spec, TruthVector(), 4, 60, kNoiseA, kNoiseR, seed + 100);
    const IdentificationResult two = Identifier(Cfg(true), kWheelbase).Identify(Pointers(train), Pointers(valid));
    const IdentificationResult one = Identifier(Cfg(false), kWheelbase).Identify(Pointers(train), Pointers(valid));
    ASSERT_TRUE(two.valid) << two.reason;
    ASSERT_TRUE(one.valid) << one.reason;
    std::printf("seed %llu: EG two %.4f%% (se %.3f%%), a_y alone %.4f%% (se %.3f%%); is %.4f Jz %.0f cv %.0f ch %.0f lv %.4f; "
                "rmse a_y %.4f yaw %.3f deg/s\n",
                static_cast<unsigned long long>(seed), 100 * (two.eg_rad_per_mps2 / eg_true - 1),
                100 * two.eg_se_rad_per_mps2 / eg_true, 100 * (one.eg_rad_per_mps2 / eg_true - 1),
                100 * one.eg_se_rad_per_mps2 / eg_true, two.params[model::kSteerRatio].value,
                two.params[model::kYawInertia].value, two.params[model::kStiffFront].value,
                two.params[model::kStiffRear].value, two.params[model::kCgToFront].value,
                two.rmse_validation_mps2, two.rmse_validation_yaw_radps / kDeg);
    EXPECT_TRUE(two.yaw_rate_output);
    EXPECT_FALSE(one.yaw_rate_output);
    EXPECT_NEAR(two.eg_rad_per_mps2, eg_true, 0.01 * eg_true) << seed;
    const auto truth = TruthVector();
    EXPECT_NEAR(two.params[model::kSteerRatio].value, truth[model::kSteerRatio], 0.005 * truth[model::kSteerRatio]);
    for (int i : {model::kYawInertia, model::kStiffFront, model::kStiffRear, model::kCgToFront}) {
      EXPECT_NEAR(two.params[i].value, truth[i], 0.03 * truth[i]) << model::kParamNames[i] << " seed " << seed;
    }
    EXPECT_NEAR(two.rmse_validation_mps2, kNoiseA, 0.1 * kNoiseA);
    EXPECT_NEAR(two.rmse_validation_yaw_radps, kNoiseR, 0.1 * kNoiseR);
    // The white noise levels the weights came from: sigma^2 tau ~ sigma^2 on white residuals.
    EXPECT_NEAR(two.noise_level_a_y, kNoiseA * kNoiseA, 0.3 * kNoiseA * kNoiseA);
    EXPECT_NEAR(two.noise_level_yaw_rate, kNoiseR * kNoiseR, 0.3 * kNoiseR * kNoiseR);
    // The yaw rate adds information on EG.
    EXPECT_LT(two.eg_se_rad_per_mps2, one.eg_se_rad_per_mps2) << seed;
  }
}

// Mean over all scored samples of (road_bank's bank force k b - the true crossfall) and of v,
// for the model `fit` at its parameters over the segments.
struct BankError {
  double mean_error_mps2 = 0, mean_speed_mps = 0;
};
BankError BankTrackingError(const Identifier& id, const IdentificationResult& fit, const SegmentList& segments,
                            const std::vector<double>& crossfall) {
  const model::ModelSpec& spec = id.spec();
  size_t bank_effect = spec.effects().size();
  for (size_t e = 0; e < spec.effects().size(); ++e) {
    if (spec.effects()[e]->info().name == "road_bank") bank_effect = e;
  }
  EXPECT_LT(bank_effect, spec.effects().size());
  const std::vector<double> params = fit.AllValues();
  const double gain = params[static_cast<size_t>(spec.param_offset(bank_effect))];
  const size_t state = static_cast<size_t>(spec.state_offset(bank_effect)), ns = static_cast<size_t>(spec.num_states());
  BankError out;
  size_t n = 0;
  for (size_t s = 0; s < segments.size(); ++s) {
    for (const Chunk& c : MakeChunks({segments[s]}, id.config().chunk_s, id.config().burn_in_s)) {
      std::vector<double> a(c.n);
      model::SimulationTrace trace;
      model::SimulateModel(spec, params.data(), kWheelbase, c.Inputs(), a.data(), &trace);
      for (size_t k = BurnInSamples(c, id.config().burn_in_s); k < c.n; ++k) {
        out.mean_error_mps2 += gain * trace.effect_states[k * ns + state] - crossfall[s];
        out.mean_speed_mps += c.samples[k].speed_mps;
        ++n;
      }
    }
  }
  out.mean_error_mps2 /= static_cast<double>(n);
  out.mean_speed_mps /= static_cast<double>(n);
  return out;
}

// Catches: a gyro offset the two-output fit cannot recover, or a road_bank observer that turns
// it into a speed-dependent bank v r0 (the observer must read r_meas - r0). Synthetic roads have
// a constant crossfall per segment (sd 0.2 m/s^2) and the gyro an offset of 0.4 deg/s.
TEST(TwoOutputs, GyroOffsetIsRecoveredAndNotAbsorbedByTheRoadBank) {
  const double r0 = 0.4 * kDeg;
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"crossfall", "gyro_offset"});
  std::vector<double> truth = TruthVector();
  truth.push_back(0.0);  // crossfall, drawn per segment
  truth.push_back(r0);
  std::vector<double> bank_train, bank_valid;
  const auto train = SyntheticTwoOutputSegments(truth_spec, truth, 16, 60, kNoiseA, kNoiseR, 41, 0.2, &bank_train);
  const auto valid = SyntheticTwoOutputSegments(truth_spec, truth, 4, 60, kNoiseA, kNoiseR, 42, 0.2, &bank_valid);
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);

  const Identifier with(Cfg(true), kWheelbase, model::ModelSpec::FromNames({"road_bank", "gyro_offset"}));
  const IdentificationResult fit = with.Identify(Pointers(train), Pointers(valid));
  ASSERT_TRUE(fit.valid) << fit.reason;
  ASSERT_EQ(fit.effect_params.size(), 2u);
  const ParameterEstimate& r0_fit = fit.effect_params[1];
  ASSERT_EQ(r0_fit.name, "gyro_offset_radps");
  const BankError bank = BankTrackingError(with, fit, Pointers(train), bank_train);
  std::printf("with gyro_offset: r0 %.4f +- %.4f deg/s (truth 0.4), EG %+.3f%% +- %.3f%%, bank error %.4f m/s^2 "
              "(v r0 = %.4f), rmse a_y %.4f yaw %.4f deg/s\n",
              r0_fit.value / kDeg, r0_fit.se / kDeg, 100 * (fit.eg_rad_per_mps2 / eg_true - 1),
              100 * fit.eg_se_rad_per_mps2 / eg_true, bank.mean_error_mps2, bank.mean_speed_mps * r0,
              fit.rmse_validation_mps2, fit.rmse_validation_yaw_radps / kDeg);
  EXPECT_NEAR(r0_fit.value, r0, 0.02 * r0);
  EXPECT_LT(r0_fit.se, 0.05 * r0);
  EXPECT_NEAR(fit.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
  EXPECT_LT(std::abs(bank.mean_error_mps2), 0.2 * bank.mean_speed_mps * r0) << "the bank absorbed the gyro offset";
  EXPECT_NEAR(fit.rmse_validation_yaw_radps, kNoiseR, 0.1 * kNoiseR);

  // Without gyro_offset the observer reads r_meas = r + r0 and the bank takes it as v r0: the
  // mechanism the effect exists for (so this test can fail when the correction is lost).
  const Identifier without(Cfg(true), kWheelbase, model::ModelSpec::FromNames({"road_bank"}));
  const IdentificationResult bad = without.Identify(Pointers(train), Pointers(valid));
  ASSERT_TRUE(bad.valid) << bad.reason;
  const BankError absorbed = BankTrackingError(without, bad, Pointers(train), bank_train);
  std::printf("without gyro_offset: EG %+.3f%%, bank error %.4f m/s^2, rmse a_y %.4f yaw %.4f deg/s\n",
              100 * (bad.eg_rad_per_mps2 / eg_true - 1), absorbed.mean_error_mps2, bad.rmse_validation_mps2,
              bad.rmse_validation_yaw_radps / kDeg);
  EXPECT_GT(std::abs(absorbed.mean_error_mps2), 0.5 * absorbed.mean_speed_mps * r0);
}

// Catches: a gyro scale error the two-output fit cannot tell from the steering ratio (the
// kinematic a_y = v r separates them): k_r = 2 % hidden, recovered with is and EG.
TEST(TwoOutputs, GyroScaleIsRecoveredWithTheSteeringRatio) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"gyro_scale"});
  std::vector<double> truth = TruthVector();
  truth.push_back(0.02);
  const auto train = SyntheticTwoOutputSegments(spec, truth, 16, 60, kNoiseA, kNoiseR, 71);
  const IdentificationResult fit = Identifier(Cfg(true), kWheelbase, spec).Identify(Pointers(train), {});
  ASSERT_TRUE(fit.valid) << fit.reason;
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  std::printf("gyro_scale: k_r %.5f +- %.5f (truth 0.02), is %.4f (truth %.2f), EG %+.3f%%\n", fit.effect_params[0].value,
              fit.effect_params[0].se, fit.params[model::kSteerRatio].value, truth[model::kSteerRatio],
              100 * (fit.eg_rad_per_mps2 / eg_true - 1));
  EXPECT_NEAR(fit.effect_params[0].value, 0.02, 0.002);
  EXPECT_NEAR(fit.params[model::kSteerRatio].value, truth[model::kSteerRatio], 0.005 * truth[model::kSteerRatio]);
  EXPECT_NEAR(fit.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
}

// Catches: an accelerometer scale error (k_a) the two-output fit cannot tell from the steering
// ratio, or a sign slip in the effect. Two seeds and both signs: with the yaw rate k_a, is and EG
// are recovered; with a_y alone the scale goes into is (the confounding the yaw rate resolves).
TEST(TwoOutputs, AccelScaleIsRecoveredWithTheYawRate) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"accel_scale"});
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  for (const auto& [k_a, seed] : {std::pair{0.025, 81u}, std::pair{-0.02, 82u}}) {
    std::vector<double> truth = TruthVector();
    truth.push_back(k_a);
    const auto train = SyntheticTwoOutputSegments(spec, truth, 16, 60, kNoiseA, kNoiseR, seed);
    const IdentificationResult fit = Identifier(Cfg(true), kWheelbase, spec).Identify(Pointers(train), {});
    ASSERT_TRUE(fit.valid) << fit.reason;
    const IdentificationResult alone = Identifier(Cfg(false), kWheelbase, spec).Identify(Pointers(train), {});
    ASSERT_TRUE(alone.valid) << alone.reason;
    std::printf("accel_scale %+.3f: two outputs k_a %+.5f +- %.5f, is %.4f, EG %+.3f%%; a_y alone k_a %+.4f +- %.4f, is %.3f\n",
                k_a, fit.effect_params[0].value, fit.effect_params[0].se, fit.params[model::kSteerRatio].value,
                100 * (fit.eg_rad_per_mps2 / eg_true - 1), alone.effect_params[0].value, alone.effect_params[0].se,
                alone.params[model::kSteerRatio].value);
    EXPECT_NEAR(fit.effect_params[0].value, k_a, 0.003);
    EXPECT_NEAR(fit.params[model::kSteerRatio].value, truth[model::kSteerRatio], 0.005 * truth[model::kSteerRatio]);
    EXPECT_NEAR(fit.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
    // a_y alone: k_a and is trade (the fit lands anywhere along the direction, its se meaningless).
    EXPECT_GT(std::abs(alone.params[model::kSteerRatio].value - truth[model::kSteerRatio]), 0.005 * truth[model::kSteerRatio])
        << "with a_y alone the scale goes (partly) into is";
  }
}

// Catches: a two-output configuration that changes the fit of a vehicle without a yaw rate
// (no signal, or a signal with gaps): it must fall back to a_y alone, result for result.
TEST(TwoOutputs, WithoutAYawRateFallsBackToAyAloneWithTheSameResult) {
  auto train = SyntheticTwoOutputSegments(model::ModelSpec(), TruthVector(), 8, 60, kNoiseA, kNoiseR, 51);
  auto valid = SyntheticTwoOutputSegments(model::ModelSpec(), TruthVector(), 2, 60, kNoiseA, kNoiseR, 52);
  auto no_yaw = [](std::vector<stats::Segment> segs) {
    for (auto& s : segs) {
      s.has_yaw_rate = false;
      for (auto& x : s.samples) x.yaw_rate_radps = 0.0f;
    }
    return segs;
  };
  auto nan_yaw = [](std::vector<stats::Segment> segs) {
    for (auto& s : segs) s.samples[s.samples.size() / 2].yaw_rate_radps = NAN;
    return segs;
  };
  const auto a_train = no_yaw(train), a_valid = no_yaw(valid);
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank"});
  const IdentificationResult ref = Identifier(Cfg(false), kWheelbase, spec).Identify(Pointers(a_train), Pointers(a_valid));
  const IdentificationResult fb = Identifier(Cfg(true), kWheelbase, spec).Identify(Pointers(a_train), Pointers(a_valid));
  ASSERT_TRUE(ref.valid && fb.valid);
  EXPECT_FALSE(fb.yaw_rate_output);
  EXPECT_EQ(fb.eg_rad_per_mps2, ref.eg_rad_per_mps2);
  EXPECT_EQ(fb.eg_se_rad_per_mps2, ref.eg_se_rad_per_mps2);
  EXPECT_EQ(fb.rmse_validation_mps2, ref.rmse_validation_mps2);
  EXPECT_EQ(fb.rmse_validation_yaw_radps, -1.0);
  bool noted = false;
  for (const auto& n : fb.identifiability.notes) noted |= n.find("a_y alone") != std::string::npos;
  EXPECT_TRUE(noted);
  // A yaw rate with a gap (NaN) in every segment: the same as none.
  const auto g_train = nan_yaw(train), g_valid = nan_yaw(valid);
  const IdentificationResult gap = Identifier(Cfg(true), kWheelbase, spec).Identify(Pointers(g_train), Pointers(g_valid));
  ASSERT_TRUE(gap.valid) << gap.reason;
  EXPECT_FALSE(gap.yaw_rate_output);
  EXPECT_EQ(gap.eg_rad_per_mps2, ref.eg_rad_per_mps2);
}

// Catches: a gyro effect whose autodiff derivative differs from the model it simulates (a term
// written for double but not for the Jet, a missing chain through the observer's input or
// gyro_delay's shifted read of it). The
// stacked (a_y, yaw-rate) Jacobian of every parameter against central differences, with
// road_bank in the model so the observer's corrected yaw-rate input is exercised too.
TEST(GyroEffects, AutodiffJacobianMatchesNumericDifferences) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset", "gyro_scale", "gyro_delay"});
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"crossfall", "gyro_offset", "gyro_scale", "gyro_delay"});
  std::vector<double> truth = TruthVector();
  truth.insert(truth.end(), {0.0, 0.4 * kDeg, 0.02, 0.05});
  const auto segs = SyntheticTwoOutputSegments(truth_spec, truth, 1, 20, kNoiseA, kNoiseR, 61, 0.2);
  const auto chunks = MakeChunks(Pointers(segs), 60, 1.5);
  ASSERT_EQ(chunks.size(), 1u);
  ASSERT_TRUE(chunks[0].has_yaw_rate());
  std::vector<double> p = TruthVector();
  p.insert(p.end(), {1.3, 0.3 * kDeg, 0.01, 0.0337});  // the delay off the sample grid (the shift interpolates)
  const size_t burn = BurnInSamples(chunks[0], 1.5);
  std::vector<double> e, jac;
  EvaluateChunk(chunks[0], burn, kWheelbase, spec, p, e, jac, true);
  ASSERT_EQ(e.size(), 2 * (chunks[0].n - burn));
  const size_t np = p.size();
  for (size_t i = 0; i < np; ++i) {
    const double h = 1e-6 * std::max(1.0, std::abs(p[i])) * (i >= 6 ? 0.01 : 1.0);
    std::vector<double> pp = p, pm = p, ep, em, unused;
    pp[i] += h;
    pm[i] -= h;
    EvaluateChunk(chunks[0], burn, kWheelbase, spec, pp, ep, unused, true);
    EvaluateChunk(chunks[0], burn, kWheelbase, spec, pm, em, unused, true);
    double max_abs = 0, max_err = 0;
    for (size_t k = 0; k < e.size(); ++k) {
      const double num = (ep[k] - em[k]) / (2 * h);
      max_abs = std::max(max_abs, std::abs(num));
      max_err = std::max(max_err, std::abs(num - jac[k * np + i]));
    }
    EXPECT_GT(max_abs, 0.0) << spec.param_name(static_cast<int>(i)) << " has no effect on the outputs";
    EXPECT_LT(max_err, 1e-4 * max_abs) << spec.param_name(static_cast<int>(i));
  }
}

}  // namespace
}  // namespace ndsid::identify

namespace ndsid::identify {
namespace {

// Catches: a two-output diagnosis that scores a_y alone (a gyro offset leaves nothing in a_y
// without road_bank, so it could not rank), mis-weights the stacked rows, or leaves yaw-rate
// sensor effects out of the candidates. Synthetic segments with a hidden gyro offset, model
// without it: gyro_offset is ranked first and significant, its one-step estimate near the truth;
// with a_y alone it is not a default candidate.
TEST(TwoOutputDiagnosis, GyroOffsetRankedFirstOnTheStackedResiduals) {
  const double r0 = -0.3 * kDeg;
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"gyro_offset"});
  std::vector<double> truth = TruthVector();
  truth.push_back(r0);
  const auto train = SyntheticTwoOutputSegments(truth_spec, truth, 12, 60, kNoiseA, kNoiseR, 91);
  const Identifier two(Cfg(true), kWheelbase, model::ModelSpec());
  const IdentificationResult fit = two.Identify(Pointers(train), {});
  ASSERT_TRUE(fit.valid) << fit.reason;
  const discover::Diagnosis d = discover::Diagnose(two, fit.AllValues(), Pointers(train));
  ASSERT_FALSE(d.ranked.empty());
  std::printf("two outputs (%s): first %s dRSS %.3g z %+.1f one-step %+.4f deg/s\n", d.outputs.c_str(),
              d.ranked[0].effect.c_str(), d.ranked[0].drss, d.ranked[0].z_robust, d.ranked[0].one_step / kDeg);
  EXPECT_EQ(d.outputs, "a_y and yaw rate");
  EXPECT_EQ(d.ranked[0].effect, "gyro_offset");
  EXPECT_TRUE(d.ranked[0].significant);
  EXPECT_NEAR(d.ranked[0].one_step, r0, 0.1 * std::abs(r0));

  const Identifier one(Cfg(false), kWheelbase, model::ModelSpec());
  const discover::Diagnosis a = discover::Diagnose(one, one.Identify(Pointers(train), {}).AllValues(), Pointers(train));
  EXPECT_EQ(a.outputs, "a_y");
  for (const auto& c : a.ranked) EXPECT_NE(c.effect, "gyro_offset") << "not scored on a_y alone";
}

}  // namespace
}  // namespace ndsid::identify
