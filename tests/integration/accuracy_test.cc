// Accuracy of the estimator on simulated naturalistic driving whose truth is known, through the
// whole pipeline (CAN log -> decode -> sync -> gate -> window -> Ceres).
#include <gtest/gtest.h>

#include <algorithm>

#include "ndsid/identify/identifier.h"
#include "sim_harness.h"

namespace ndsid::testing {
namespace {

// The run's identification with both outputs fitted (identification.outputs [a_y, yaw_rate]).
identify::Identifier TwoOutputIdentifier(const SimulatedRun& run, const model::ModelSpec& spec) {
  config::IdentificationConfig cfg = run.config->identification;
  cfg.yaw_rate_output = true;
  return identify::Identifier(cfg, run.config->vehicle.wheelbase_m, spec);
}

// Catches: a biased EG or a fit that stops short of the noise floor, in the default suite:
// 2 h of clean driving with random road crossfall (the minimum data set), model base + road_bank.
// Measured: +0.05 % mean over 7 seeds (sigma ~0.11 %), see docs/accuracy.md. Bound: 1 %. The
// noise floor is the true model's RMSE on the same held-out drives.
TEST(Accuracy, CleanTwoHoursEgWithinOnePercentAndRmseAtNoiseFloor) {
  const SimulatedRun run = SimulateAndReplay("acc_short", 101, 2.0);
  ASSERT_GT(run.window.gated_hours, 1.2);
  ASSERT_FALSE(run.window.validation.empty());
  const auto& id = run.pipeline->identifier();
  const identify::IdentificationResult r = id.Identify(run.window.training, run.window.validation,
                                                       std::optional<std::vector<double>>{});
  ASSERT_TRUE(r.valid) << r.reason;
  const double err = r.eg_rad_per_mps2 - run.eg_truth;
  std::printf("EG %.4f ± %.4f deg/g, truth %.4f (%+.2f %%)\n", r.eg_deg_per_g, r.eg_se_deg_per_g,
              model::EgToDegPerG(run.eg_truth), 100 * err / run.eg_truth);
  EXPECT_LT(std::abs(err) / run.eg_truth, 0.01);
  EXPECT_LT(r.eg_se_rad_per_mps2 / run.eg_truth, 0.01);
  // Noise floor: the true model's RMSE on the same held-out drives.
  const double floor = NoiseFloor(run, id.spec());
  std::printf("validation RMSE %.4f, noise floor %.4f\n", r.rmse_validation_mps2, floor);
  EXPECT_LT(r.rmse_validation_mps2, 1.10 * floor) << "floor " << floor;
  EXPECT_GT(r.rmse_validation_mps2, 0.9 * floor);
}

// Catches: a yaw-rate latency effect with the wrong sign or time base, or one that misreads the
// measured yaw rate the road_bank observer uses. The simulator delays the gyro exactly
// (r_meas(t) = r(t - tau), interpolated on its 100 Hz history); the model's gyro_delay delays the
// modelled yaw rate on the fit's 50 Hz grid. Two outputs, 1 h each, no latency and two
// magnitudes, three seeds: tau within 10 ms (measured +5.9, -6.2, +3.6 ms: the fit grid and the
// decimation), EG within 1 %, the yaw-rate residual at most 1.1x the true model's.
TEST(Accuracy, GyroLatencyRecoveredWithTwoOutputs) {
  for (const auto& [tau_ms, seed] : {std::pair{0.0, 113u}, std::pair{40.0, 111u}, std::pair{90.0, 112u}}) {
    const SimulatedRun run = SimulateAndReplay("acc_gyro_delay", seed, 1.0, {"gyro_delay_ms=" + std::to_string(tau_ms)},
                                               {"road_bank", "gyro_delay"});
    const identify::Identifier id = TwoOutputIdentifier(run, run.pipeline->identifier().spec());
    const identify::IdentificationResult r = id.Identify(run.window.training, run.window.validation,
                                                         std::optional<std::vector<double>>{});
    ASSERT_TRUE(r.valid) << r.reason;
    ASSERT_TRUE(r.yaw_rate_output);
    ASSERT_EQ(r.effect_params.size(), 2u);  // road_bank's gain, gyro_delay_s
    const auto& tau = r.effect_params[1];
    ASSERT_EQ(tau.name, "gyro_delay_s");
    const std::vector<double> truth = TruthVector(run, id.spec());
    const double floor_r = id.RmseYawRate(truth, run.window.validation);
    std::printf("gyro latency %.0f ms: fitted %.1f ± %.1f ms; EG %+.2f %%; yaw-rate RMSE %.4f deg/s (floor %.4f)\n", tau_ms,
                1e3 * tau.value, 1e3 * tau.se, 100 * (r.eg_rad_per_mps2 / run.eg_truth - 1),
                r.rmse_validation_yaw_radps * 180 / M_PI, floor_r * 180 / M_PI);
    EXPECT_NEAR(tau.value, tau_ms / 1000, 0.010) << seed;
    EXPECT_LT(std::abs(r.eg_rad_per_mps2 / run.eg_truth - 1), 0.01) << seed;
    EXPECT_LT(r.rmse_validation_yaw_radps, 1.10 * floor_r) << seed;
  }
}

// Catches: a speed scale left to the lateral outputs, where it trades with is and an
// accelerometer scale (a_y alone: uniqueness 0.00). Any fit of a model with speed_scale reads
// the speed signal's scale against the longitudinal accelerometer from its training data
// (stats/speed_scale.h) as a prior: the same data with a_x hidden from the fit are the
// comparison. Speed scale +3 % and -2 %, a_y alone, 1 h each. Stated tolerances: the scale
// within 0.01 (the prior's sd is 0.005, the accelerometer's own scale tolerance), EG within 1 %.
// (Not "…Longitudinal…": a name containing "Long" is filtered into the long label.)
TEST(Accuracy, SpeedScaleReadFromTheForwardAccelerometer) {
  for (const auto& [pct, seed] : {std::pair{3.0, 131u}, std::pair{-2.0, 132u}}) {
    const SimulatedRun run = SimulateAndReplay("acc_speed_scale", seed, 1.0, {"speed_scale_pct=" + std::to_string(pct)},
                                               {"road_bank", "speed_scale"});
    const identify::Identifier& id = run.pipeline->identifier();
    const auto with = id.Identify(run.window.training, run.window.validation, std::optional<std::vector<double>>{});
    // The same segments without their a_x: no evidence, speed_scale free.
    std::vector<stats::Segment> blind;
    for (const stats::Segment* seg : run.window.training) {
      blind.push_back(*seg);
      blind.back().has_long_accel = false;
    }
    std::vector<const stats::Segment*> blind_ptrs;
    for (const auto& seg : blind) blind_ptrs.push_back(&seg);
    const auto without = id.Identify(blind_ptrs, run.window.validation, std::optional<std::vector<double>>{});
    ASSERT_TRUE(with.valid) << with.reason;
    auto eps = [](const identify::IdentificationResult& r) {
      for (const auto& p : r.effect_params)
        if (p.name == "speed_scale") return p;
      ADD_FAILURE() << "speed_scale not in the fit";
      return identify::ParameterEstimate{};
    };
    bool noted = false;
    for (const auto& n : with.identifiability.notes) noted = noted || n.find("speed scale against a_x") != std::string::npos;
    EXPECT_TRUE(noted) << "the evidence is named in the identifiability notes";
    const double err_with = with.eg_rad_per_mps2 / run.eg_truth - 1, err_without = without.eg_rad_per_mps2 / run.eg_truth - 1;
    std::printf("speed scale %+.1f %%: with a_x %.4f +- %.4f, EG %+.2f %%; without %.4f +- %.4f, EG %+.2f %%\n", pct,
                eps(with).value, eps(with).se, 100 * err_with, eps(without).value, eps(without).se, 100 * err_without);
    EXPECT_NEAR(eps(with).value, pct / 100, 0.01);
    EXPECT_LT(std::abs(err_with), 0.01);
    EXPECT_LT(eps(with).se, eps(without).se) << "the evidence narrows it";
  }
}

// Catches: a speed-offset effect with the wrong sign, unit or place (the speed the dynamics see),
// and one that the yaw rate cannot pin. The simulator adds the offset to the vehicle speed signal
// only, while moving; two outputs, 1 h each: no offset, +2 and -3 km/h, and -1.5 km/h together
// with a gyro offset of +0.3 deg/s (model with both). Asserted: the offset within 0.1 m/s
// (0.36 km/h), both outputs' held-out RMSE at most 1.1x the true model's, and, where an offset is
// hidden, EG and the a_y RMSE better than the same model without speed_offset. EG only within
// 2.5 %: with speed_offset free, clean data leave it -0.20..+0.16 km/h off at 3-8 sigma (not
// shrinking with 4 h of data) and EG moves with it (-1.8..+1.4 % over 16 runs, docs/two-outputs.md):
// the 1/v signature takes up a structural misfit of the model on the simulator (the fit's
// held-out RMSE sits below the true parameters'), so the effect is added on evidence only.
TEST(Accuracy, SpeedOffsetRecoveredWithTwoOutputs) {
  struct Case {
    double kph;
    double gyro_degps;
    unsigned seed;
  };
  for (const Case& c : {Case{0.0, 0.0, 121u}, Case{2.0, 0.0, 122u}, Case{-3.0, 0.0, 123u}, Case{-1.5, 0.3, 124u}}) {
    std::vector<std::string> hidden = {"speed_offset_kph=" + std::to_string(c.kph)};
    std::vector<std::string> model = {"road_bank", "speed_offset"};
    if (c.gyro_degps != 0) {
      hidden.push_back("gyro_offset_degps=" + std::to_string(c.gyro_degps));
      model.push_back("gyro_offset");
    }
    const SimulatedRun run = SimulateAndReplay("acc_speed_offset", c.seed, 1.0, hidden, model);
    const identify::Identifier id = TwoOutputIdentifier(run, run.pipeline->identifier().spec());
    const identify::IdentificationResult r = id.Identify(run.window.training, run.window.validation,
                                                         std::optional<std::vector<double>>{});
    ASSERT_TRUE(r.valid) << r.reason;
    ASSERT_TRUE(r.yaw_rate_output);
    auto param = [&](const std::string& name) {
      for (const auto& p : r.effect_params)
        if (p.name == name) return p;
      ADD_FAILURE() << name << " not in the fit";
      return identify::ParameterEstimate{};
    };
    const identify::ParameterEstimate off = param("speed_offset_mps");
    const double truth = c.kph / 3.6;
    const std::vector<double> truth_vec = TruthVector(run, id.spec());
    const double floor_a = id.Rmse(truth_vec, run.window.validation);
    const double floor_r = id.RmseYawRate(truth_vec, run.window.validation);
    std::printf("speed offset %+.2f km/h (gyro %+.2f deg/s): fitted %+.3f ± %.3f km/h; EG %+.2f %%; held-out RMSE a_y %.4f "
                "(floor %.4f), yaw %.4f deg/s (floor %.4f)\n",
                c.kph, c.gyro_degps, 3.6 * off.value, 3.6 * off.se, 100 * (r.eg_rad_per_mps2 / run.eg_truth - 1),
                r.rmse_validation_mps2, floor_a, r.rmse_validation_yaw_radps * 180 / M_PI, floor_r * 180 / M_PI);
    if (c.gyro_degps != 0) {
      const identify::ParameterEstimate r0 = param("gyro_offset_radps");
      std::printf("  gyro offset fitted %+.4f ± %.4f deg/s\n", r0.value * 180 / M_PI, r0.se * 180 / M_PI);
      EXPECT_NEAR(r0.value * 180 / M_PI, c.gyro_degps, 0.03) << c.seed;
    }
    EXPECT_NEAR(off.value, truth, 0.1) << c.seed;
    EXPECT_LT(std::abs(r.eg_rad_per_mps2 / run.eg_truth - 1), 0.025) << c.seed;
    if (c.kph != 0) {  // the same model without speed_offset: worse EG and a_y residual
      std::vector<std::string> without = model;
      without.erase(std::find(without.begin(), without.end(), "speed_offset"));
      const identify::Identifier id0 = TwoOutputIdentifier(run, model::ModelSpec::FromNames(without, run.pipeline->library()));
      const identify::IdentificationResult r0 = id0.Identify(run.window.training, run.window.validation,
                                                             std::optional<std::vector<double>>{});
      ASSERT_TRUE(r0.valid) << r0.reason;
      std::printf("  without speed_offset: EG %+.2f %%, held-out RMSE a_y %.4f, yaw %.4f deg/s\n",
                  100 * (r0.eg_rad_per_mps2 / run.eg_truth - 1), r0.rmse_validation_mps2,
                  r0.rmse_validation_yaw_radps * 180 / M_PI);
      EXPECT_LT(std::abs(r.eg_rad_per_mps2 / run.eg_truth - 1), std::abs(r0.eg_rad_per_mps2 / run.eg_truth - 1)) << c.seed;
      EXPECT_LT(r.rmse_validation_mps2, r0.rmse_validation_mps2) << c.seed;
    }
    EXPECT_LT(r.rmse_validation_mps2, 1.10 * floor_a) << c.seed;
    EXPECT_LT(r.rmse_validation_yaw_radps, 1.10 * floor_r) << c.seed;
  }
}

// Catches: EG accuracy that does not improve with data: 10 h, within 1 % (measured: see
// docs/accuracy.md) and at the noise floor.
TEST(AccuracyLong, TenHoursCleanEgWithinOnePercent) {
  const SimulatedRun run = SimulateAndReplay("acc_long", 31, 10.0);
  const auto& id = run.pipeline->identifier();
  const identify::IdentificationResult r = id.Identify(run.window.training, run.window.validation,
                                                       std::optional<std::vector<double>>{});
  ASSERT_TRUE(r.valid) << r.reason;
  std::printf("EG %.4f ± %.4f deg/g, truth %.4f (%+.2f %%)\n", r.eg_deg_per_g, r.eg_se_deg_per_g,
              model::EgToDegPerG(run.eg_truth), 100 * (r.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth);
  EXPECT_LT(std::abs(r.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.01);
  const double floor = NoiseFloor(run, id.spec());
  EXPECT_LT(r.rmse_validation_mps2, 1.10 * floor);
}

// Catches: a dishonest standard error, and a shared bias. Across 20 independent 1 h data sets
// the 95 % interval must cover the truth at least 18 times (90 %), the reported
// sigma must match the spread of the estimates (sd / mean sigma in [0.7, 1.4]) and the mean
// error stays below 0.5 %.
TEST(AccuracyLong, StandardErrorHonestAcrossTwentySeeds) {
  std::vector<double> eg, se;
  int covered = 0;
  double eg_truth = 0;
  for (uint64_t seed = 200; seed < 220; ++seed) {
    const SimulatedRun run = SimulateAndReplay("acc_cov", seed, 1.0);
    const identify::IdentificationResult r = run.pipeline->identifier().Identify(
        run.window.training, run.window.validation, std::optional<std::vector<double>>{});
    if (!r.valid) continue;
    eg_truth = run.eg_truth;
    eg.push_back(r.eg_rad_per_mps2);
    se.push_back(r.eg_se_rad_per_mps2);
    covered += std::abs(r.eg_rad_per_mps2 - run.eg_truth) <= 1.96 * r.eg_se_rad_per_mps2;
    std::printf("seed %lu: EG %.4f ± %.4f deg/g (truth %.4f)\n", static_cast<unsigned long>(seed), r.eg_deg_per_g,
                r.eg_se_deg_per_g, model::EgToDegPerG(run.eg_truth));
  }
  ASSERT_GE(eg.size(), 20u);
  double mean = 0, mean_se = 0, var = 0;
  for (size_t i = 0; i < eg.size(); ++i) {
    mean += eg[i] / eg.size();
    mean_se += se[i] / se.size();
  }
  for (double e : eg) var += (e - mean) * (e - mean) / (eg.size() - 1);
  const double ratio = std::sqrt(var) / mean_se;
  std::printf("sd/mean sigma %.2f, mean error %+.2f %%, 95 %% interval covers the truth in %d of %zu\n", ratio,
              100 * (mean - eg_truth) / eg_truth, covered, eg.size());
  EXPECT_GE(covered, 18);
  EXPECT_GT(ratio, 0.7);
  EXPECT_LT(ratio, 1.4);
  EXPECT_LT(std::abs(mean - eg_truth) / eg_truth, 0.005);
}

// Catches: an adequacy signal that never fires on plenty of clean data, or fires early. The
// pipeline re-identifies every hour of data time over a 12 h clean run (as the daemon does):
// the state must reach ADEQUATE, never before the configured change window + hold period of
// gated hours, and never while EG is still more than 1 % off the truth.
TEST(AccuracyLong, AdequacyReachedOnLongCleanRunAndNotEarly) {
  const SimulatedRun run = SimulateAndReplay("acc_adequacy", 47, 12.0, {}, {"road_bank"}, {.identify_every_s = 3600});
  ASSERT_GE(run.history.size(), 8u);
  const auto& cfg = run.config->adequacy;
  bool reached = false;
  for (const pipeline::Estimate& e : run.history) {
    const double err = std::abs(e.fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth;
    std::printf("%.2f gated h: %s EG %.4f (%+.2f %%) %s\n", e.adequacy.gated_hours,
                adequacy::StateName(e.adequacy.state), e.fit.eg_deg_per_g, 100 * err, e.adequacy.explanation.c_str());
    if (e.adequacy.state != adequacy::State::kAdequate) continue;
    reached = true;
    EXPECT_LT(err, 0.01) << "ADEQUATE claimed at " << e.adequacy.gated_hours << " h with EG " << 100 * err << " % off";
    EXPECT_GE(e.adequacy.gated_hours, cfg.change_window_h + cfg.hold_h);
  }
  EXPECT_TRUE(reached) << "never ADEQUATE over " << run.window.gated_hours << " gated h";
}

}  // namespace
}  // namespace ndsid::testing
