// The model-improvement loop proven on simulated driving with hidden effects (compare
// -> where it fails -> which effect is missing -> add it -> the error falls). Through the whole
// pipeline: simulator -> CAN log -> decode -> gate -> window -> fit -> diagnosis -> ladder.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "ndsid/discover/diagnosis.h"
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
  double steer_skew_s = 0;              // hidden steering skew, found by step 0 (time alignment)
  bool align = true;                    // run step 0
  bool two_outputs = false;             // identification.outputs [a_y, yaw_rate]
  double yaw_skew_s = 0;                // hidden gyro latency, found by step 0 (two outputs)
  double speed_skew_s = 0;              // hidden speed-signal latency, found by step 0
  double eg_tolerance = 0.01;           // |EG / truth - 1| after the ladder
  bool added_before_ranking = false;    // added from model-free evidence before the first diagnosis (speed_scale from a_x)
  std::vector<std::string> ranked_first_in = {};  // if set: the first-ranked effect is one of these (a confounded group)
  double speed_unskewed_within_s = -1;  // if >= 0 (no hidden speed latency): an applied speed shift stays within this
  const char* param2 = "";              // a second recovered parameter ("" = none), its truth and tolerance
  double truth_value2 = 0;
  double tolerance2 = 0;
};

void PrintDiagnosis(const discover::Diagnosis& d) {
  for (const auto& c : d.ranked) {
    std::printf("  %-16s dRSS %.3g  one-step %+.4g %s  uniq %.2f  z %+.1f%s\n", c.effect.c_str(), c.drss, c.one_step,
                c.unit.c_str(), c.uniqueness, c.z_robust, c.significant ? "  significant" : "");
  }
  if (d.unexplained) std::printf("  UNEXPLAINED: %s\n", d.unexplained_text.c_str());
}

void RunCase(const HiddenCase& c, uint64_t seed, double hours) {
  if (std::getenv("NDSID_DEBUG")) spdlog::set_level(spdlog::level::debug);  // the alignment's and ladder's decisions
  const SimulatedRun run = SimulateAndReplay(c.name, seed, hours, c.simulated);
  config::IdentificationConfig cfg = run.config->identification;
  cfg.yaw_rate_output = c.two_outputs;
  discover::LadderOptions options;
  options.align = c.align;
  if (!std::getenv("NO_STANDSTILL")) options.standstill = run.window.standstill;  // as ndsid diagnose does
  options.speed_scale_evidence = stats::EstimateSpeedScale(run.window.training);   // as ndsid diagnose does
  std::printf("%s: %s\n", c.name, options.speed_scale_evidence.note.c_str());
  const discover::Ladder ladder = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank"}, model::EffectLibrary::Builtin(),
                                                             run.window.training, run.window.validation, options);
  ASSERT_FALSE(ladder.rungs.empty());
  ASSERT_FALSE(ladder.diagnoses.empty());
  // Step 0: a hidden skew is found (stated tolerance +-32 ms: a steering lag trades with lv and
  // Jz); without one, no latency beyond the simulator's message phases (< 10 ms) is applied.
  // With two outputs the yaw rate's latency too (relative to a_y, as the simulator's): a hidden
  // gyro latency within 15 ms (the message phases of a_y and the yaw rate differ by up to 10 ms),
  // and the steering not pulled by it (within the 12 ms of a clean run, or its own hidden skew's
  // tolerance). Without a hidden one, no yaw-rate shift beyond 12 ms is applied.
  for (const auto& l : ladder.alignment) {
    std::printf("%s: step 0 %s %+.1f ± %.1f ms%s\n", c.name, config::RoleKey(l.role), 1e3 * l.latency_s, 1e3 * l.se_s,
                l.apply ? " applied" : "");
    if (l.role == config::Role::kYawRate && c.two_outputs && c.align) {
      if (c.yaw_skew_s > 0) {
        EXPECT_TRUE(l.apply);
        EXPECT_NEAR(l.latency_s, c.yaw_skew_s, 0.015);
      } else if (l.apply) {
        EXPECT_LT(std::abs(l.latency_s), 0.012);
      }
    }
    if (l.role == config::Role::kSpeed && c.speed_skew_s == 0 && c.speed_unskewed_within_s >= 0 && l.apply) {
      EXPECT_LT(std::abs(l.latency_s), c.speed_unskewed_within_s) << "a speed latency the simulator does not have";
    }
    if (l.role == config::Role::kSpeed && c.speed_skew_s > 0 && c.align) {
      // A speed latency is weak (through v^2 and v r only) and found short: within 35 %
      // (measured: 200 ms as 153.8 +- 4.7 ms with a_y alone, 250 ms as 213.7 +- 3.5 ms with two
      // outputs; the joint refit's sigma is not honest here; docs/two-outputs.md).
      EXPECT_TRUE(l.apply);
      EXPECT_NEAR(l.latency_s, c.speed_skew_s, 0.35 * c.speed_skew_s);
    }
    if (l.role != config::Role::kSteeringWheelAngle) continue;
    if (c.steer_skew_s > 0) {
      EXPECT_TRUE(l.apply);
      EXPECT_NEAR(l.latency_s, c.steer_skew_s, 0.032);
    } else if (l.apply) {
      EXPECT_LT(std::abs(l.latency_s), 0.012);
    }
  }
  if (c.align) {
    EXPECT_EQ(ladder.alignment.size(), 3u);
  }
  if (c.yaw_skew_s > 0) {  // aligned, the yaw rate is explained (its floor corrected for the shift)
    for (const auto& v : ladder.verdicts) EXPECT_FALSE(v.unexplained) << v.text;
  }
  std::printf("%s: first diagnosis\n", c.name);
  PrintDiagnosis(ladder.diagnoses.front());
  for (const auto& r : ladder.rungs) {
    std::printf("  rung %-40s RMSE %.4f / %.4f  EG %.4f ± %.4f deg/g\n", r.model.c_str(), r.fit.rmse_train_mps2,
                r.fit.rmse_validation_mps2, r.fit.eg_deg_per_g, r.fit.eg_se_deg_per_g);
  }
  std::printf("  stop: %s\n", ladder.stop_reason.c_str());
  std::vector<std::string> added;  // what the final model holds beyond the start
  for (const std::string& e : ladder.final_effects)
    if (e != "road_bank") added.push_back(e);
  const std::string& first = ladder.diagnoses.front().ranked.front().effect;
  if (!c.confounded.empty()) {
    // Physically confounded with the model's other terms: one member of the group, any.
    auto in_group = [&](const std::string& e) { return std::find(c.confounded.begin(), c.confounded.end(), e) != c.confounded.end(); };
    EXPECT_TRUE(in_group(first)) << "ranked first: " << first;
    ASSERT_EQ(added.size(), 1u);
    EXPECT_TRUE(in_group(added[0])) << added[0];
  } else {
    // The hidden effect is ranked first by the score test, and the ladder adds exactly it.
    const std::vector<std::string>& first_in = c.ranked_first_in.empty() ? c.expected : c.ranked_first_in;
    if (!first_in.empty() && !c.added_before_ranking) {
      EXPECT_NE(std::find(first_in.begin(), first_in.end(), first), first_in.end()) << "ranked first: " << first;
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
  if (c.steer_skew_s > 0 && c.align) truth_effects.push_back("steer_delay");
  if (c.yaw_skew_s > 0 && c.align) truth_effects.push_back("gyro_delay");
  if (c.speed_skew_s > 0 && c.align) truth_effects.push_back("speed_delay");
  const double floor = NoiseFloor(run, model::ModelSpec::FromNames(truth_effects));
  std::printf("  validation RMSE %.4f, noise floor %.4f\n", final_fit.rmse_validation_mps2, floor);
  EXPECT_LT(final_fit.rmse_validation_mps2, 1.10 * floor);
  if (c.two_outputs) {
    // Both outputs at their floors: the yaw rate's too (the true model's held-out yaw-rate RMSE).
    const model::ModelSpec truth_spec = model::ModelSpec::FromNames(truth_effects);
    const identify::Identifier truth_model(cfg, run.config->vehicle.wheelbase_m, truth_spec);
    const double floor_r = truth_model.RmseYawRate(TruthVector(run, truth_spec), run.window.validation);
    std::printf("  validation yaw-rate RMSE %.4f deg/s, noise floor %.4f deg/s\n", final_fit.rmse_validation_yaw_radps * 180 / M_PI,
                floor_r * 180 / M_PI);
    ASSERT_TRUE(final_fit.yaw_rate_output);
    EXPECT_LT(final_fit.rmse_validation_yaw_radps, 1.10 * floor_r);
  }
  if (!c.expected.empty()) {
    EXPECT_LT(final_fit.rmse_validation_mps2, ladder.rungs.front().fit.rmse_validation_mps2);
  }
  // The effect's parameter is recovered; EG's bias from the hidden effect is gone: EG within 1 %
  // of the truth (the clean model is unbiased to ~0.1 %, docs/accuracy.md).
  for (const auto& p : final_fit.effect_params) std::printf("  final %s %.5g ± %.2g\n", p.name.c_str(), p.value, p.se);
  const std::pair<const char*, std::pair<double, double>> checked[] = {{c.param, {c.truth_value, c.tolerance}},
                                                                       {c.param2, {c.truth_value2, c.tolerance2}}};
  for (const auto& [param, truth] : checked) {
    if (!*param || !c.confounded.empty()) continue;
    bool found = false;
    for (const auto& p : final_fit.effect_params) {
      if (p.name != param) continue;
      found = true;
      std::printf("  %s %.4f ± %.4f, truth %.4f\n", p.name.c_str(), p.value, p.se, truth.first);
      EXPECT_NEAR(p.value, truth.first, truth.second) << p.name;
    }
    EXPECT_TRUE(found) << param;
  }
  std::printf("  EG %.4f deg/g, truth %.4f (%+.2f %%)\n", final_fit.eg_deg_per_g, model::EgToDegPerG(run.eg_truth),
              100 * (final_fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth);
  EXPECT_LT(std::abs(final_fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, c.eg_tolerance);
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

// With road_bank in the model (the bank tracked through the yaw rate), a steering offset and an
// accelerometer bias both leave a constant in the steady-state residual: the observer keeps the
// model's yaw rate on the measured one, so an offset shows up as a constant tyre force. Measured:
// accel_bias and steer_offset score alike (dRSS 1.31e3 each, uniqueness 0.99), the ladder adds
// accel_bias (b 0.1018 of 0.1 m/s^2) and EG is +0.07 %. Transients and the standstill a_y tell
// them apart (measured before the standstill evidence; the test below asserts that separation);
// this one asserts the group and, when the bias is chosen, its value.
TEST(HiddenEffectLong, AccelerometerBiasConfoundedWithSteerOffset) {
  RunCase({"bias", {"accel_bias_mps2=0.1"}, {"accel_bias"}, {"accel_bias", "steer_offset", "crossfall"},
           "accel_bias_mps2", 0.1, 0.015},
          43, 1.5);
}

// The standstill evidence separates them (docs/two-outputs.md): the stops' mean a_y is the bias
// plus a zero-mean cross-slope, so accel_bias is ranked first, added, and recovered; a steering
// offset would leave the stops at zero. Another magnitude and sign than the test above.
TEST(HiddenEffectLong, AccelerometerBiasFoundWithStandstillEvidence) {
  RunCase({"bias_standstill", {"accel_bias_mps2=-0.13"}, {"accel_bias"}, {}, "accel_bias_mps2", -0.13, 0.02}, 54, 1.5);
  RunCase({"bias_standstill_2", {"accel_bias_mps2=0.09"}, {"accel_bias"}, {}, "accel_bias_mps2", 0.09, 0.02}, 55, 1.5);
}

// A steering offset and an accelerometer bias together. With road_bank the driving data fit
// only d0 - is EG b: the first of the two the ladder adds takes up the other (measured before
// the stops judged it: the steering offset at 2.3 times its truth, or the bias at 0.35 for 0.2
// m/s^2, each with a standard error a hundred times smaller than its error). A candidate whose
// refit contradicts the stops is rejected, and after the climb the bias the stops determine is
// added (the ladder's standstill rung): both recovered, EG within 1 %. Other signs, magnitudes
// and seeds than the cases above; a_y alone and with the yaw rate.
TEST(HiddenEffectLong, SteeringOffsetAndAccelerometerBiasSplitByTheStops) {
  HiddenCase c{"steer_bias", {"steer_offset_deg=-1.1", "accel_bias_mps2=0.2"}, {"steer_offset", "accel_bias"}, {},
               "steer_offset_rad", -1.1 * M_PI / 180, 0.003};
  c.param2 = "accel_bias_mps2", c.truth_value2 = 0.2, c.tolerance2 = 0.03;
  c.two_outputs = true;
  RunCase(c, 71, 1.5);
  HiddenCase d{"steer_bias_2", {"steer_offset_deg=0.9", "accel_bias_mps2=-0.18"}, {"steer_offset", "accel_bias"}, {},
               "steer_offset_rad", 0.9 * M_PI / 180, 0.003};
  d.param2 = "accel_bias_mps2", d.truth_value2 = -0.18, d.tolerance2 = 0.03;
  RunCase(d, 72, 1.5);
}

// Two outputs (identification.outputs [a_y, yaw_rate]) and real sensors' errors. A gyro offset:
// with road_bank in the start model the bank observer makes the model's yaw rate follow the
// measured one, so the offset leaves a bank of about r0/G and in a_y a residual of
// -l r0 / (v EG), which a steering offset explains in part. The stops' mean yaw
// rate is the offset itself: with that evidence gyro_offset is ranked first and added, and the
// observer then reads r_meas - r0.
TEST(HiddenEffectLong, GyroOffsetFoundWithTwoOutputs) {
  HiddenCase c{"gyro", {"gyro_offset_degps=0.4"}, {"gyro_offset"}, {}, "gyro_offset_radps", 0.4 * M_PI / 180,
               0.02 * M_PI / 180};
  c.two_outputs = true;
  RunCase(c, 61, 1.5);
}

// A gyro offset and a steering offset together, other signs and magnitudes: both are added
// (one after the other), EG within 1 %.
TEST(HiddenEffectLong, GyroAndSteeringOffsetsFoundTogetherWithTwoOutputs) {
  HiddenCase c{"gyro_steer", {"gyro_offset_degps=-0.3", "steer_offset_deg=1.2"}, {"gyro_offset", "steer_offset"}, {},
               "gyro_offset_radps", -0.3 * M_PI / 180, 0.02 * M_PI / 180};
  c.two_outputs = true;
  RunCase(c, 62, 1.5);
}

// The same gyro offset with a_y alone (the default outputs): road_bank's observer reads the
// measured yaw rate, so the offset reaches a_y through the bank it builds (-l r0 / (v EG)), and
// gyro_offset is a candidate whenever such an effect is in the model. The stops fix it.
TEST(HiddenEffectLong, GyroOffsetFoundWithAyAloneThroughTheBankObserver) {
  RunCase({"gyro_ay", {"gyro_offset_degps=0.35"}, {"gyro_offset"}, {}, "gyro_offset_radps", 0.35 * M_PI / 180,
           0.02 * M_PI / 180},
          66, 1.5);
}

// Accelerometer bias with two outputs and the standstill evidence: a_y - v r shows the bias
// and the stops read it; ranked first and added.
TEST(HiddenEffectLong, AccelerometerBiasFoundWithTwoOutputs) {
  HiddenCase c{"bias2", {"accel_bias_mps2=0.15"}, {"accel_bias"}, {}, "accel_bias_mps2", 0.15, 0.02};
  c.two_outputs = true;
  RunCase(c, 67, 1.5);
}

// A yaw-rate sensor latency (60 ms, exact in the simulator) with two outputs: step 0 finds it
// (a joint refit of model and gyro_delay, then the yaw-rate profile after the steering's) and
// aligns the data, leaving the steering where it is; then nothing is
// left for the ladder (gyro_delay, the same latency as a model effect, is tried and not added),
// both outputs reach their floors and EG is within 1 %.
TEST(HiddenEffectLong, GyroLatencyFoundByTimeAlignmentWithTwoOutputs) {
  HiddenCase c{"gyro_lat", {"gyro_delay_ms=60"}, {}, {}, "", 0, 0};
  c.two_outputs = true;
  c.yaw_skew_s = 0.060;
  c.speed_unskewed_within_s = 0.012;  // a held yaw-rate profile would apply -13.1 ms
  RunCase(c, 68, 1.5);
}

// A gyro latency and a steering skew together, other sizes and another seed (100 ms and 40 ms,
// both exact in the simulator): step 0 splits them, each within its tolerance (the yaw rate's
// relative to a_y).
TEST(HiddenEffectLong, GyroLatencyAndSteeringSkewSplitByTimeAlignmentWithTwoOutputs) {
  HiddenCase c{"gyro_lat_steer", {"gyro_delay_ms=100", "steer_delay_ms=40"}, {}, {}, "", 0, 0, 0.040};
  c.two_outputs = true;
  c.yaw_skew_s = 0.100;
  c.speed_unskewed_within_s = 0.012;
  RunCase(c, 168, 1.5);
}

// Step 0 on gyro latencies of other sizes, seeds and companions (two outputs): 30 and 150 ms
// alone, 80 ms with a 60 ms steering skew, and 60 ms beside a gyro offset and beside a speed
// offset, which the ladder then adds. Each latency within its tolerance, no spurious shift
// applied, the companion added and nothing else, EG within 1 % (2.5 % with the speed offset:
// its structural error, SpeedOffsetFoundWithTwoOutputs).
TEST(HiddenEffectLong, GyroLatencyOfOtherSizesAndWithCompanionsWithTwoOutputs) {
  struct Variant {
    const char* name;
    std::vector<std::string> simulated, expected;
    double yaw_s, steer_s;
    uint64_t seed;
    double eg_tolerance;
  };
  const std::vector<Variant> variants = {
      {"gyro30", {"gyro_delay_ms=30"}, {}, 0.030, 0, 301, 0.01},
      {"gyro150", {"gyro_delay_ms=150"}, {}, 0.150, 0, 302, 0.01},
      {"gyro80_steer60", {"gyro_delay_ms=80", "steer_delay_ms=60"}, {}, 0.080, 0.060, 303, 0.01},
      {"gyro60_offset", {"gyro_delay_ms=60", "gyro_offset_degps=0.3"}, {"gyro_offset"}, 0.060, 0, 304, 0.01},
      {"gyro60_speed_off", {"gyro_delay_ms=60", "speed_offset_kph=-2"}, {"speed_offset"}, 0.060, 0, 305, 0.025},
  };
  for (const Variant& v : variants) {
    HiddenCase c{v.name, v.simulated, v.expected, {}, "", 0, 0, v.steer_s};
    c.two_outputs = true;
    c.yaw_skew_s = v.yaw_s;
    c.eg_tolerance = v.eg_tolerance;
    c.speed_unskewed_within_s = 0.012;  // the message phases' reach, as for the steering
    RunCase(c, v.seed, 1.5);
  }
}

// A speed-signal offset (-2 km/h, the vehicle speed only) with two outputs: a_y - v r leaves
// -c r, so speed_offset is ranked first and added, the offset recovered within 0.1 m/s and both
// outputs at their floors. EG only within 2.5 % (measured +1.81 %, offset -0.483 +- 0.010 of
// -0.556 m/s): with speed_offset in the model EG moves with the offset's structural error
// (docs/two-outputs.md, "The speed signal's errors"); 1 % is not met for this effect.
TEST(HiddenEffectLong, SpeedOffsetFoundWithTwoOutputs) {
  HiddenCase c{"speed_off", {"speed_offset_kph=-2"}, {"speed_offset"}, {}, "speed_offset_mps", -2 / 3.6, 0.1};
  c.two_outputs = true;
  c.eg_tolerance = 0.025;
  RunCase(c, 69, 1.5);
}

// A speed-signal latency (200 ms, exact in the simulator) with a_y alone: step 0 finds it with
// a joint refit of model and shift (speed_delay), and the steering once more on the speed-aligned
// data (a speed latency pulls the steering's shift); nothing is left for the ladder.
TEST(HiddenEffectLong, SpeedLatencyFoundByTimeAlignment) {
  HiddenCase c{"speed_lat", {"speed_delay_ms=200"}, {}, {}, "", 0, 0};
  c.speed_skew_s = 0.200;
  RunCase(c, 70, 1.5);
}

// Clean data with two outputs: the yaw-rate sensor effects are candidates too; nothing is added.
TEST(HiddenEffectLong, CleanDataNothingAddedWithTwoOutputs) {
  HiddenCase c{"none2", {}, {}, {}, "", 0, 0};
  c.two_outputs = true;
  RunCase(c, 65, 1.5);
}

// Body roll with two outputs. The tracked bank takes up the steady part of g phi (a bank leaning
// out of the turn in proportion to a_y), so the start model matches both outputs with EG off by
// the roll's size (5 deg/g: -7.9 %), and the score tests rank the whole steady-state group
// {speed_scale, roll, gyro_scale, accel_scale} alike. No refit lowers a held-out RMSE by the
// ladder's 3 %; roll's lowers both (a_y -1.4 %, yaw rate -1.6 % on seed 63) and moves EG by
// +7.6 % (34 sigma): the EG-relevant rule adds it, the group member with the lowest BIC
// (docs/two-outputs.md, "An effect that changes EG"). Stated tolerances: EG 1 %, the roll
// gradient 15 % (measured 7 % short: the bank keeps a little of it).
TEST(HiddenEffectLong, BodyRollFoundWithTwoOutputsByItsEffectOnEg) {
  const std::vector<std::string> group{"speed_scale", "roll", "gyro_scale", "accel_scale"};
  for (const auto& [deg_per_g, seed] : {std::pair{5.0, 63}, std::pair{3.0, 163}}) {
    const double k = deg_per_g * M_PI / 180 / 9.81;
    HiddenCase c{"roll2", {"roll_gradient_deg_per_g=" + std::to_string(deg_per_g)}, {"roll"}, {},
                 "roll_gradient_rad_per_mps2", k, 0.15 * k};
    c.two_outputs = true;
    c.ranked_first_in = group;
    RunCase(c, seed, 1.5);
  }
}

// Body roll 7 deg/g and a gyro offset of 0.3 deg/s together. After gyro_offset, speed_scale
// lowers the held-out RMSE by 35 % (it stands in for the roll) and passed the 3 % rule first in
// rank order, leaving EG -11.7 %; the speed scale read from a_x (0 within 0.02 %) is now its
// prior, the refit's -3.4 % lies 6.7 prior sd from it and is rejected, and roll is added.
// Measured (seed 263): roll 0.0118 of 0.01245 rad/(m/s^2), EG -0.63 %.
TEST(HiddenEffectLong, BodyRollAndGyroOffsetTogetherWithTwoOutputs) {
  const double k = 7 * M_PI / 180 / 9.81;
  HiddenCase c{"roll7_gyro", {"roll_gradient_deg_per_g=7", "gyro_offset_degps=0.3"}, {"gyro_offset", "roll"}, {},
               "roll_gradient_rad_per_mps2", k, 0.15 * k};
  c.two_outputs = true;
  RunCase(c, 263, 1.5);
}

// A speed scale of 3 % with two outputs. In a_y and r it is exactly an accelerometer scale with
// is and EG re-labelled (the refits with speed_scale and with accel_scale reach the same held-out
// RMSE, EG +0.5 % and -6.2 %), so the lateral outputs cannot name it. The longitudinal channel
// can: dv_meas/dt = (1 + eps) a_x, read model-free (stats/speed_scale.h) as +2.97 +- 0.01 %; the
// ladder adds speed_scale with that prior before its first rung. Stated tolerances: eps 0.01
// (the prior's sd is 0.005, the accelerometer's own scale tolerance), EG 1 %.
TEST(HiddenEffectLong, SpeedScaleFoundFromTheLongitudinalAccelerationWithTwoOutputs) {
  HiddenCase c{"speed_scale2", {"speed_scale_pct=3"}, {"speed_scale"}, {}, "speed_scale", 0.03, 0.01};
  c.two_outputs = true;
  c.added_before_ranking = true;
  RunCase(c, 64, 1.5);
}

// A signal time skew is what step 0 (time alignment) is for: an 80 ms steering skew is found
// there and the ladder, on the aligned data, adds nothing. Stated tolerance +-32 ms (40 %): the
// steering lag's sensitivity is only 21 % unique (it trades with lv and Jz).
TEST(HiddenEffectLong, SteeringTimeSkewFoundByTimeAlignment) {
  RunCase({"delay", {"steer_delay_ms=80"}, {}, {}, "", 0, 0, 0.08}, 44, 1.5);
}

// Without step 0 the same skew is a lag effect for the ladder: steer_delay ranked first and
// added (measured 56 ms of 80).
TEST(HiddenEffectLong, SteeringTimeSkewFoundAsLagEffectWithoutAlignment) {
  RunCase({"delay_noalign", {"steer_delay_ms=80"}, {"steer_delay"}, {}, "steer_delay_s", 0.08, 0.032, 0, false}, 44, 1.5);
}

// Two hidden effects found one after the other by the ladder (step 0 off, so that the skew is
// one of the ladder's rungs), and with step 0: the skew there, the offset by the ladder.
TEST(HiddenEffectLong, TwoEffectsFoundOneAfterTheOther) {
  RunCase({"two", {"steer_offset_deg=1.5", "steer_delay_ms=80"}, {"steer_offset", "steer_delay"}, {}, "steer_offset_rad",
           1.5 * M_PI / 180, 0.003, 0, false},
          45, 1.5);
  RunCase({"two_aligned", {"steer_offset_deg=1.5", "steer_delay_ms=80"}, {"steer_offset"}, {}, "steer_offset_rad",
           1.5 * M_PI / 180, 0.003, 0.08},
          45, 1.5);
}

// Effects the bus signals cannot tell from the fitted parameters (physics.md §4): the diagnosis
// must report the hidden effect as confounded (uniqueness < 0.05, naming what it trades with)
// instead of claiming it. Returns the run for further fits.
SimulatedRun ExpectReportedConfounded(const char* name, uint64_t seed, const std::string& simulated,
                                      const std::string& effect) {
  SimulatedRun run = SimulateAndReplay(name, seed, 1.5, {simulated});
  const identify::Identifier id(run.config->identification, run.config->vehicle.wheelbase_m,
                                model::ModelSpec::FromNames({"road_bank"}));
  const auto fit = id.Identify(run.window.training, run.window.validation, std::optional<std::vector<double>>{});
  EXPECT_TRUE(fit.valid);
  const discover::Diagnosis d = discover::Diagnose(id, fit.AllValues(), run.window.training, {});
  PrintDiagnosis(d);
  bool seen = false;
  for (const auto& c : d.ranked) {
    if (c.effect != effect) continue;
    seen = true;
    EXPECT_LT(c.uniqueness, 0.05) << effect;
    EXPECT_FALSE(c.confounded_with.empty()) << effect << ": confounded with nothing named";
    std::string with;
    for (const auto& w : c.confounded_with) with += " " + w;
    std::printf("  %s confounded with:%s\n", effect.c_str(), with.c_str());
  }
  EXPECT_TRUE(seen) << effect << " not among the candidates";
  const double err = (fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth;
  std::printf("  EG %.4f deg/g, truth %.4f (%+.2f %%)\n", fit.eg_deg_per_g, model::EgToDegPerG(run.eg_truth), 100 * err);
  return run;
}

// base + road_bank + `effect`, fitted with a prior on its parameter; prints the parameter and
// EG's error and returns the fit.
identify::IdentificationResult FitWithPrior(const SimulatedRun& run, const std::string& effect,
                                            const config::ParameterPrior& prior) {
  config::IdentificationConfig cfg = run.config->identification;
  cfg.priors.push_back(prior);
  const identify::Identifier id(cfg, run.config->vehicle.wheelbase_m, model::ModelSpec::FromNames({"road_bank", effect}));
  const auto fit = id.Identify(run.window.training, run.window.validation, std::optional<std::vector<double>>{});
  EXPECT_TRUE(fit.valid) << fit.reason;
  for (const auto& p : fit.effect_params) {
    if (p.name == prior.name) std::printf("  %s %.5f ± %.5f (prior %.5f ± %.5f)\n", p.name.c_str(), p.value, p.se, prior.value, prior.sd);
  }
  std::printf("  with the prior: EG %.4f ± %.4f deg/g (%+.2f %%)\n", fit.eg_deg_per_g, fit.eg_se_deg_per_g,
              100 * (fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth);
  return fit;
}

// A lever arm of 0.8 m (a_meas += x_s r'): its signature is a lag like a steering skew's, so the
// two score alike (measured dRSS 4.03 vs 4.05, uniqueness 0.01 / 0.05). The ladder adds the lag
// group until the held-out RMSE stops falling; it must end at the noise floor, with lever_arm
// among the additions and EG within 1 % (measured: steer_delay then lever_arm, EG -0.13 %).
//
// Step 0 (time alignment) sees the same lag: with it on, the lever arm is taken for a steering
// skew (measured +15 ms applied), the fit reaches the noise floor and EG stays within 1 %
// (-0.18 %), but the effect is misnamed. The ladder's part is therefore checked with step 0
// off, and step 0's outcome separately.
TEST(HiddenEffectLong, LeverArmFoundWithinTheLagGroup) {
  const SimulatedRun run = SimulateAndReplay("lever", 47, 1.5, {"lever_arm_m=0.8"});
  const auto& cfg = run.config->identification;
  {
    const discover::Ladder aligned = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank"}, model::EffectLibrary::Builtin(),
                                                                run.window.training, run.window.validation);
    const auto& fit = aligned.rungs.back().fit;
    for (const auto& l : aligned.alignment) {
      std::printf("  step 0 %s %+.1f ± %.1f ms%s\n", config::RoleKey(l.role), 1e3 * l.latency_s, 1e3 * l.se_s,
                  l.apply ? " applied" : "");
    }
    std::printf("  with step 0: %s, validation RMSE %.4f, EG %.4f\n", fit.model.c_str(), fit.rmse_validation_mps2,
                fit.eg_deg_per_g);
    EXPECT_LT(fit.rmse_validation_mps2, 1.10 * NoiseFloor(run, model::ModelSpec::FromNames({"road_bank", "lever_arm"})));
    EXPECT_LT(std::abs(fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.01);
  }
  discover::LadderOptions no_align;
  no_align.align = false;
  const discover::Ladder ladder = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank"}, model::EffectLibrary::Builtin(),
                                                             run.window.training, run.window.validation, no_align);
  ASSERT_FALSE(ladder.diagnoses.empty());
  PrintDiagnosis(ladder.diagnoses.front());
  const std::vector<std::string> lag_group{"lever_arm", "steer_delay", "relaxation"};
  const std::string& first = ladder.diagnoses.front().ranked.front().effect;
  EXPECT_NE(std::find(lag_group.begin(), lag_group.end(), first), lag_group.end()) << first;
  bool added = false;
  for (const auto& r : ladder.rungs) added |= r.added == "lever_arm";
  EXPECT_TRUE(added);
  const double floor = NoiseFloor(run, model::ModelSpec::FromNames({"road_bank", "lever_arm"}));
  const auto& fit = ladder.rungs.back().fit;
  std::printf("  %s: validation RMSE %.4f, floor %.4f, EG %.4f\n", fit.model.c_str(), fit.rmse_validation_mps2, floor,
              fit.eg_deg_per_g);
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.01);
  // The lever arm itself, stated tolerance +-0.3 m (its signature is 99 % absorbable by lv/Jz).
  for (const auto& p : fit.effect_params) {
    if (p.name == "lever_arm_m") {
      std::printf("  lever_arm %.3f ± %.3f m (truth 0.8)\n", p.value, p.se);
      EXPECT_NEAR(p.value, 0.8, 0.3);
    }
  }
}

// Body roll 5 deg/g: with the yaw rate in the model (road_bank), the steady part of g*phi scales
// the measured a_y exactly as a smaller EG does, and the 1.5 Hz roll mode is too weak a
// separator in everyday driving: reported confounded (uniqueness 0.00). Measured: EG -8.1 %,
// RMSE at the noise floor — the data cannot show roll. With the roll gradient's data-sheet
// value as a prior (model.priors: 5 +- 0.5 deg/g) and roll added, EG is within 1 % and its
// sigma carries the prior's uncertainty.
TEST(HiddenEffectLong, BodyRollReportedConfoundedAndResolvedByAPrior) {
  const SimulatedRun run = ExpectReportedConfounded("roll", 48, "roll_gradient_deg_per_g=5", "roll");
  const double k = 5 * M_PI / 180 / 9.81;  // the truth, stated as the prior
  const auto fit = FitWithPrior(run, "roll", {"roll_gradient_rad_per_mps2", k, 0.1 * k, "test"});
  ASSERT_TRUE(fit.valid);
  const double err = (fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth;
  EXPECT_LT(std::abs(err), 0.01);
  EXPECT_LT(std::abs(err), 2.5 * fit.eg_se_rad_per_mps2 / run.eg_truth);  // sigma honest about it
}

// Speed scale +3 %: it sits in the Ackermann term and trades with l/is (physics.md §4: "weakly");
// reported confounded (uniqueness 0.00). Measured: EG -2.8 %, RMSE at the noise floor. With a
// measured tyre rolling radius as a prior (3 +- 0.5 %) and speed_scale added, EG is within 1 %.
TEST(HiddenEffectLong, SpeedScaleReportedConfoundedAndResolvedByAPrior) {
  const SimulatedRun run = ExpectReportedConfounded("speed", 49, "speed_scale_pct=3", "speed_scale");
  const auto fit = FitWithPrior(run, "speed_scale", {"speed_scale", 0.03, 0.005, "test"});
  ASSERT_TRUE(fit.valid);
  const double err = (fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth;
  EXPECT_LT(std::abs(err), 0.01);
}

// Tyre relaxation 0.6 m: measured ranked first by the score test (z -5.0), but its held-out
// gain is below the ladder's 3 % rule, so the ladder does not add it (EG +0.30 % without it).
// Added by hand (config or --effects), the fit reaches the noise floor, keeps EG within 1 % and
// recovers sigma within the stated +-0.25 m: measured 0.395 m of 0.6 — 80 % of the effect's
// signature is absorbed by lv/Jz (uniqueness 0.20) and the simulator's few-ms message skew is a
// lag of its own, so sigma is weakly determined on 1.5 h.
TEST(HiddenEffectLong, TyreRelaxationRankedFirstAndRecoveredWhenAdded) {
  const SimulatedRun run = SimulateAndReplay("relax", 50, 1.5, {"relaxation_length_m=0.6"});
  const auto& cfg = run.config->identification;
  const double l = run.config->vehicle.wheelbase_m;
  const identify::Identifier base(cfg, l, model::ModelSpec::FromNames({"road_bank"}));
  const auto base_fit = base.Identify(run.window.training, run.window.validation, std::optional<std::vector<double>>{});
  ASSERT_TRUE(base_fit.valid);
  const discover::Diagnosis d = discover::Diagnose(base, base_fit.AllValues(), run.window.training, {});
  PrintDiagnosis(d);
  ASSERT_FALSE(d.ranked.empty());
  EXPECT_EQ(d.ranked.front().effect, "relaxation");
  const auto spec = model::ModelSpec::FromNames({"road_bank", "relaxation"});
  const identify::Identifier with(cfg, l, spec);
  const auto fit = with.Identify(run.window.training, run.window.validation, base_fit.AllValues());
  ASSERT_TRUE(fit.valid);
  const double floor = NoiseFloor(run, spec);
  double sigma = -1;
  for (const auto& p : fit.effect_params) {
    if (p.name == "relaxation_length_m") sigma = p.value;
  }
  std::printf("  relaxation %.3f m (truth 0.6), validation RMSE %.4f -> %.4f, floor %.4f, EG %.4f -> %.4f (truth %.4f)\n",
              sigma, base_fit.rmse_validation_mps2, fit.rmse_validation_mps2, floor, base_fit.eg_deg_per_g,
              fit.eg_deg_per_g, model::EgToDegPerG(run.eg_truth));
  EXPECT_NEAR(sigma, 0.6, 0.25);
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.01);
}

// Superelevation 5 %: the bank tracked by road_bank contains it; nothing is added, EG within 1 %
// (measured +0.06 %).
TEST(HiddenEffectLong, SuperelevationAbsorbedByTheTrackedBank) {
  RunCase({"superel", {"superelevation_pct=5"}, {}, {}, "", 0, 0}, 51, 1.5);
}

// Tyre saturation, mu 0.6 (a low-grip road; at mu ~0.9 it hardly shows inside the gated linear
// range of everyday driving, as the study observed): ranked first, added, EG bias removed.
// Measured (2 h): held-out RMSE 0.0507 -> 0.0415, EG +2.7 % -> +0.38 %, 1/mu^2 = 2.43 of 2.78
// (mu 0.64 of 0.6); stated tolerance +-0.6 on 1/mu^2 (about +-0.05 on mu).
TEST(HiddenEffectLong, TyreSaturationFoundAddedAndEgBiasRemoved) {
  RunCase({"tyre", {"tyre_mu=0.6"}, {"tyre_saturation"}, {}, "tyre_inv_mu_sq", 1.0 / 0.36, 0.6}, 52, 2.0);
}

// The road's crossfall (±3 %, always on in the simulator) hidden from a base model without
// road_bank: the ladder, started from the bare single-track model, ranks road_bank first and
// adds it. Measured (2 h, seed 7): road_bank 27.7 % of the RSS, held-out RMSE 0.094 -> 0.040,
// EG +1.3 % -> +0.09 %.
TEST(HiddenEffectLong, RoadCrossfallFoundFromTheBareModel) {
  const SimulatedRun run = SimulateAndReplay("crossfall", 7, 2.0, {}, {});
  const auto& cfg = run.config->identification;
  const discover::Ladder ladder = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {}, model::EffectLibrary::Builtin(),
                                                             run.window.training, run.window.validation);
  ASSERT_FALSE(ladder.diagnoses.empty());
  PrintDiagnosis(ladder.diagnoses.front());
  EXPECT_EQ(ladder.diagnoses.front().ranked.front().effect, "road_bank");
  ASSERT_EQ(ladder.rungs.size(), 2u);
  EXPECT_EQ(ladder.rungs[1].added, "road_bank");
  const auto& base = ladder.rungs[0].fit;
  const auto& fit = ladder.rungs[1].fit;
  const double floor = NoiseFloor(run, model::ModelSpec::FromNames({"road_bank"}));
  std::printf("  held-out RMSE %.4f -> %.4f (floor %.4f), EG %.4f -> %.4f (truth %.4f)\n", base.rmse_validation_mps2,
              fit.rmse_validation_mps2, floor, base.eg_deg_per_g, fit.eg_deg_per_g, model::EgToDegPerG(run.eg_truth));
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor);
  EXPECT_GT(base.rmse_validation_mps2, 1.5 * floor);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.01);
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
  discover::DiagnosisOptions opt;
  for (const auto& n : model::BuiltinEffectNames()) {
    if (n != "steer_delay" && n != "relaxation" && n != "road_bank" &&
        !model::ModelSpec::FromNames({n}).effects()[0]->info().yaw_rate_sensor)  // a_y-only diagnosis
      opt.candidates.push_back(n);
  }
  const discover::Diagnosis d = discover::Diagnose(id, fit.AllValues(), run.window.training, opt);
  PrintDiagnosis(d);
  for (const auto& s : d.signatures) std::printf("  signature %-45s r %+.3f z %+.1f\n", s.signal.c_str(), s.correlation, s.z_robust);
  EXPECT_TRUE(d.unexplained) << "expected unexplained structure";
  EXPECT_NE(d.unexplained_text.find("steering rate"), std::string::npos) << d.unexplained_text;
}

// A gyro re-zeroed at every ignition (physics.md §4, r0 per drive): 0.2 deg/s plus U(-0.4, 0.4)
// per drive, two outputs. The ladder, from road_bank, must end on gyro_offset_per_drive and not
// on gyro_offset (which scores first by its common part, and is tried in its per-drive form
// because the spread between drives is significant: a global offset would make the held-out
// drives worse, measured 0.0785 -> 0.178 m/s^2); every drive's
// offset within 0.03 deg/s of the simulator's (se about 0.005), EG within 1 %, and both outputs'
// held-out RMSE within 10 % of the true model's (each held-out drive at its own fitted offset,
// the true model at every drive's true offset).
TEST(HiddenEffectLong, GyroOffsetPerDriveFoundWithTwoOutputs) {
  const SimulatedRun run = SimulateAndReplay("gyro_drive", 71, 1.5, {"gyro_offset_degps=0.2", "gyro_offset_drive_degps=0.4"});
  config::IdentificationConfig cfg = run.config->identification;
  cfg.yaw_rate_output = true;
  discover::LadderOptions options;
  options.standstill = run.window.standstill;
  options.speed_scale_evidence = stats::EstimateSpeedScale(run.window.training);
  const discover::Ladder ladder = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank"},
                                                             model::EffectLibrary::Builtin(), run.window.training,
                                                             run.window.validation, options);
  ASSERT_FALSE(ladder.diagnoses.empty());
  PrintDiagnosis(ladder.diagnoses.front());
  for (const auto& r : ladder.rungs) {
    std::printf("  rung %-44s + %-22s RMSE %.4f / %.4f  EG %.4f ± %.4f deg/g\n", r.model.c_str(), r.added.c_str(),
                r.fit.rmse_train_mps2, r.fit.rmse_validation_mps2, r.fit.eg_deg_per_g, r.fit.eg_se_deg_per_g);
  }
  const identify::IdentificationResult& fit = ladder.rungs.back().fit;
  const model::ModelSpec final_spec = model::ModelSpec::FromNames(
      [&] {
        std::vector<std::string> effects;
        const std::string& m = ladder.rungs.back().model;
        for (size_t at = m.find(" + "); at != std::string::npos; at = m.find(" + ", at + 3)) {
          const size_t end = m.find(" + ", at + 3);
          effects.push_back(m.substr(at + 3, end == std::string::npos ? std::string::npos : end - at - 3));
        }
        return effects;
      }());
  const auto names = final_spec.effect_names();
  EXPECT_NE(std::find(names.begin(), names.end(), "gyro_offset_per_drive"), names.end()) << ladder.rungs.back().model;
  EXPECT_EQ(std::find(names.begin(), names.end(), "gyro_offset"), names.end()) << ladder.rungs.back().model;
  ASSERT_FALSE(fit.drive_values.empty());
  for (const auto& v : fit.drive_values) {
    ASSERT_LT(static_cast<size_t>(v.drive_id), run.drive_gyro_offset_degps.size());
    const double truth = run.drive_gyro_offset_degps[static_cast<size_t>(v.drive_id)];
    std::printf("  drive %lld%s: %s %.4f ± %.4f deg/s, truth %.4f\n", static_cast<long long>(v.drive_id),
                v.reference ? " (reference)" : v.validation ? " (held out)" : "", v.param.c_str(), v.value * 180 / M_PI,
                v.se * 180 / M_PI, truth);
    EXPECT_NEAR(v.value * 180 / M_PI, truth, 0.03) << "drive " << v.drive_id;
  }
  std::printf("  EG %.4f deg/g, truth %.4f (%+.2f %%)\n", fit.eg_deg_per_g, model::EgToDegPerG(run.eg_truth),
              100 * (fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 - run.eg_truth) / run.eg_truth, 0.01);
  // The true model: every drive (none is a reference) at its true offset.
  const auto truth_spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset_per_drive"});
  identify::Identifier truth_model(cfg, run.config->vehicle.wheelbase_m, truth_spec);
  std::vector<identify::DriveValue> true_offsets;
  for (size_t d = 0; d < run.drive_gyro_offset_degps.size(); ++d)
    true_offsets.push_back({static_cast<int64_t>(d), "gyro_offset_radps", run.drive_gyro_offset_degps[d] * M_PI / 180, 0, false, false});
  truth_model.set_drive_values(true_offsets);
  const double floor_a = truth_model.Rmse(TruthVector(run, truth_spec), run.window.validation);
  const double floor_r = truth_model.RmseYawRate(TruthVector(run, truth_spec), run.window.validation);
  std::printf("  held-out RMSE a_y %.4f (floor %.4f), yaw rate %.4f deg/s (floor %.4f)\n", fit.rmse_validation_mps2, floor_a,
              fit.rmse_validation_yaw_radps * 180 / M_PI, floor_r * 180 / M_PI);
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor_a);
  EXPECT_LT(fit.rmse_validation_yaw_radps, 1.10 * floor_r);
}

// Mass / load change per drive (physics.md §4: "EG drifts between drives", identifiable per
// drive): drive i carries schedule[i % 4] = 0, 250, 100, 350 kg extra (Jz scaled alike). The
// diagnosis must rank load_change first, the ladder add it; the fitted load ratios are the true
// mass ratios to the reference drive (the first training drive) within 0.03, EG is the reference
// drive's true EG within 1 %, and the held-out RMSE (each held-out drive's ratio fitted with the
// parameters held) is within 10 % of the true model's.
TEST(HiddenEffectLong, LoadChangeBetweenDrivesFoundAndEgAtTheReferenceLoad) {
  ReplayTweaks tweaks;
  tweaks.mass_schedule_kg = {0, 250, 100, 350};
  const SimulatedRun run = SimulateAndReplay("load", 53, 2.0, {}, {"road_bank"}, tweaks);
  const auto& cfg = run.config->identification;
  const double m0 = run.truth_base[model::kMass];
  auto true_mass = [&](int64_t drive) { return m0 + tweaks.mass_schedule_kg[static_cast<size_t>(drive) % 4]; };
  const discover::Ladder ladder = discover::ClimbErrorLadder(cfg, run.config->vehicle.wheelbase_m, {"road_bank"}, model::EffectLibrary::Builtin(),
                                                             run.window.training, run.window.validation);
  ASSERT_FALSE(ladder.diagnoses.empty());
  PrintDiagnosis(ladder.diagnoses.front());
  for (const auto& r : ladder.rungs) {
    std::printf("  rung %-44s RMSE %.4f / %.4f  EG %.4f ± %.4f deg/g\n", r.model.c_str(), r.fit.rmse_train_mps2,
                r.fit.rmse_validation_mps2, r.fit.eg_deg_per_g, r.fit.eg_se_deg_per_g);
  }
  EXPECT_EQ(ladder.diagnoses.front().ranked.front().effect, "load_change");
  ASSERT_GE(ladder.rungs.size(), 2u);
  EXPECT_EQ(ladder.rungs[1].added, "load_change");
  const auto& fit = ladder.rungs.back().fit;
  ASSERT_GE(fit.drive_values.size(), 3u);
  int64_t reference = -1;
  for (const auto& l : fit.drive_values) {
    if (l.reference) reference = l.drive_id;
  }
  ASSERT_GE(reference, 0);
  for (const auto& l : fit.drive_values) {
    const double truth = true_mass(l.drive_id) / true_mass(reference);
    std::printf("  drive %lld%s: %s %.4f ± %.4f, truth %.4f\n", static_cast<long long>(l.drive_id),
                l.reference ? " (reference)" : l.validation ? " (held out)" : "", l.param.c_str(), l.value, l.se, truth);
    EXPECT_EQ(l.param, "load_ratio");
    EXPECT_NEAR(l.value, truth, 0.03) << "drive " << l.drive_id;
  }
  // EG of the reference drive's load (EG is proportional to m at fixed tyres and lv).
  const double eg_ref = run.eg_truth * true_mass(reference) / m0;
  const auto& base = ladder.rungs.front().fit;
  std::printf("  EG %.4f -> %.4f deg/g, truth at the reference load %.4f (%+.2f %%)\n", base.eg_deg_per_g, fit.eg_deg_per_g,
              model::EgToDegPerG(eg_ref), 100 * (fit.eg_rad_per_mps2 - eg_ref) / eg_ref);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 - eg_ref) / eg_ref, 0.01);
  // The true model: truth parameters, each drive at its true mass ratio to the nominal car.
  // Every drive, the reference included, carries its own value (none is the vector's).
  const auto spec = model::ModelSpec::FromNames({"road_bank", "load_change"});
  identify::Identifier truth_model(cfg, run.config->vehicle.wheelbase_m, spec);
  std::vector<identify::DriveValue> true_loads;
  for (const auto& l : fit.drive_values) true_loads.push_back({l.drive_id, "load_ratio", true_mass(l.drive_id) / m0, 0, false, false});
  truth_model.set_drive_values(true_loads);
  const double floor = truth_model.Rmse(TruthVector(run, spec), run.window.validation);
  std::printf("  held-out RMSE %.4f -> %.4f, floor %.4f\n", base.rmse_validation_mps2, fit.rmse_validation_mps2, floor);
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor);
}

}  // namespace
}  // namespace ndsid::testing

