// Step 0's contest (physics.md §5.0): a hidden effect whose signature resembles a time shift must
// not be taken for one. A lever arm (a_y,meas = a_y + x r') reads as a lead of a_y of x/v; step 0
// found +37…+45 ms on the steering and the yaw rate, the ladder then never tried the lever arm and
// a_y stayed 7 % above the clean model's. Now the shifts compete with the candidates that resemble
// them (or the guard rejects them, the yaw rate compared as read at whole samples), and the
// ladder adds the effect. A real latency still wins over its look-alikes.
// Two outputs, the example vehicle's model (road_bank + gyro_offset), as `ndsid diagnose` runs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ndsid/discover/diagnosis.h"
#include "sim_harness.h"

namespace ndsid::testing {
namespace {

struct Climbed {
  SimulatedRun run;
  discover::Ladder ladder;
};

// training_only: every drive trains and none is held out (a single recording), so step 0's
// guard and the ladder judge the training errors.
Climbed Climb(const std::string& name, uint64_t seed, const std::vector<std::string>& simulated, bool training_only = false) {
  ReplayTweaks tweaks;
  tweaks.yaw_rate_output = true;
  Climbed c{SimulateAndReplay(name, seed, 0.6, simulated, {"road_bank", "gyro_offset"}, tweaks), {}};
  discover::LadderOptions options;
  options.standstill = c.run.window.standstill;
  options.speed_scale_evidence = stats::EstimateSpeedScale(c.run.window.training);
  identify::SegmentList training = c.run.window.training, validation = c.run.window.validation;
  if (training_only) {
    training.insert(training.end(), validation.begin(), validation.end());
    validation.clear();
  }
  c.ladder = discover::ClimbErrorLadder(c.run.config->identification, c.run.config->vehicle.wheelbase_m, {"road_bank", "gyro_offset"},
                                        model::EffectLibrary::Builtin(), training, validation, options);
  for (const auto& l : c.ladder.alignment)
    std::printf("  step 0 %s %+.1f ± %.1f ms%s\n", config::RoleKey(l.role), 1e3 * l.latency_s, 1e3 * l.se_s, l.apply ? " applied" : "");
  if (!c.ladder.look_alike.empty()) std::printf("  look-alike %s: %s\n", c.ladder.look_alike.c_str(), c.ladder.look_alike_why.c_str());
  if (!c.ladder.alignment_rejected.empty()) std::printf("  shifts not applied: %s\n", c.ladder.alignment_rejected.c_str());
  for (const auto& t : c.ladder.trials)
    if (t.step < 0) std::printf("  contest + %s: %s\n", t.effect.c_str(), t.why.c_str());
  for (const auto& r : c.ladder.rungs)
    std::printf("  rung %s: held-out %.4f, EG %.4f ± %.4f\n", r.model.c_str(), r.fit.rmse_validation_mps2, r.fit.eg_deg_per_g,
                r.fit.eg_se_deg_per_g);
  return c;
}

bool Added(const discover::Ladder& ladder, const std::string& effect) {
  return std::any_of(ladder.rungs.begin(), ladder.rungs.end(), [&](const discover::Rung& r) { return r.added == effect; });
}

double AppliedLatency(const discover::Ladder& ladder, config::Role role) {
  for (const auto& l : ladder.alignment)
    if (l.role == role && l.apply) return l.latency_s;
  return 0.0;
}

// The lever arm found and added, no steering shift beyond the simulator's message phases
// (12 ms), held-out a_y within 10 % of the true model's RMSE on the same drives (the floor), EG
// within 1 % of the truth, the arm within 3 of its standard errors of the truth.
void ExpectLeverArmFound(const Climbed& c, double lever_m) {
  const discover::Ladder& ladder = c.ladder;
  EXPECT_TRUE(Added(ladder, "lever_arm"));
  EXPECT_LT(std::abs(AppliedLatency(ladder, config::Role::kSteeringWheelAngle)), 0.012);
  const auto& fit = ladder.rungs.back().fit;
  const double floor = NoiseFloor(c.run, model::ModelSpec::FromNames({"road_bank", "gyro_offset", "lever_arm"}));
  std::printf("  final held-out a_y %.4f, the true model's %.4f (%.3fx); EG %+.2f %%\n", fit.rmse_validation_mps2, floor,
              fit.rmse_validation_mps2 / floor, 100 * (fit.eg_rad_per_mps2 / c.run.eg_truth - 1));
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 / c.run.eg_truth - 1), 0.01);
  bool seen = false;
  for (const auto& p : fit.effect_params) {
    if (p.name != "lever_arm_m") continue;
    seen = true;
    std::printf("  lever_arm %.3f ± %.3f m (truth %.2f)\n", p.value, p.se, lever_m);
    EXPECT_LT(std::abs(p.value - lever_m), 3 * p.se);
  }
  EXPECT_TRUE(seen);
}

TEST(LookAlike, LeverArmAheadIsNotTakenForShifts) {
  for (uint64_t seed : {31u, 32u}) {
    SCOPED_TRACE(seed);
    ExpectLeverArmFound(Climb("lever_ahead", seed, {"lever_arm_m=0.8"}), 0.8);
  }
}

TEST(LookAlike, LeverArmBehindIsNotTakenForShifts) {
  ExpectLeverArmFound(Climb("lever_behind", 33, {"lever_arm_m=-0.7"}), -0.7);
}

// A lever arm beside a real gyro latency (60 ms): here the contest cannot decide. On the data as
// recorded the arm's refit lowers the held-out a_y by 1.7 % only (the latency dominates), below
// the margin its path needs; pursued anyway, its path (the arm, then its own shifts: the yaw rate
// +69 ms) and the shifts alone (steering +47 ms, yaw rate +108 ms) reached the same held-out
// errors (-37.6 % and -37.8 % summed over both outputs). The shifts are kept and the steering's
// shift stands in for the arm. What holds: EG within 1 % of the truth and the held-out a_y within
// 10 % of the true model's.
TEST(LookAlike, LeverArmBesideAGyroLatencyLeavesEgRight) {
  const Climbed c = Climb("lever_gyro", 34, {"lever_arm_m=0.8", "gyro_delay_ms=60"});
  const auto& fit = c.ladder.rungs.back().fit;
  const double floor = NoiseFloor(c.run, model::ModelSpec::FromNames({"road_bank", "gyro_offset", "lever_arm", "gyro_delay"}));
  std::printf("  final held-out a_y %.4f, the true model's %.4f (%.3fx); EG %+.2f %%\n", fit.rmse_validation_mps2, floor,
              fit.rmse_validation_mps2 / floor, 100 * (fit.eg_rad_per_mps2 / c.run.eg_truth - 1));
  EXPECT_GT(AppliedLatency(c.ladder, config::Role::kYawRate), 0.030);
  EXPECT_LT(fit.rmse_validation_mps2, 1.10 * floor);
  EXPECT_LT(std::abs(fit.eg_rad_per_mps2 / c.run.eg_truth - 1), 0.01);
}

// A real steering skew wins over its look-alikes: applied within 12 ms, no look-alike added
// before it, no lever arm in the final model.
TEST(LookAlike, ARealSteeringSkewWinsTheContest) {
  const Climbed c = Climb("steer_skew", 35, {"steer_delay_ms=40"});
  EXPECT_TRUE(c.ladder.look_alike.empty()) << c.ladder.look_alike;
  EXPECT_NEAR(AppliedLatency(c.ladder, config::Role::kSteeringWheelAngle), 0.040, 0.012);
  EXPECT_FALSE(Added(c.ladder, "lever_arm"));
  EXPECT_LT(std::abs(c.ladder.rungs.back().fit.eg_rad_per_mps2 / c.run.eg_truth - 1), 0.01);
}

// With no drive held out, the errors step 0's guard judges are the training data's, which any
// free shift lowers a little: the shifts then need the margin an effect needs (3 % on an output).
// A speed-sensor scale (3 %) or a gyro scale (4 %) the starting model lacks, and no latency: on
// these seeds the shifts found on the failing model (the speed -10 … -22 ms) lowered the training
// a_y by 0.5 % and were applied; now they are not, and the ladder adds the speed scale with EG
// within 1 % of the truth. A real 40 ms steering skew is still applied, within 12 ms.
TEST(LookAlike, WithNoDriveHeldOutAShiftNeedsAnEffectsMargin) {
  const auto no_shift = [](const Climbed& c) {
    for (config::Role role : {config::Role::kSteeringWheelAngle, config::Role::kSpeed, config::Role::kYawRate})
      EXPECT_EQ(AppliedLatency(c.ladder, role), 0.0) << config::RoleKey(role);
  };
  for (uint64_t seed : {36u, 40u}) {
    SCOPED_TRACE(seed);
    const Climbed c = Climb("training_only", seed, {"speed_scale_pct=3"}, true);
    no_shift(c);
    EXPECT_TRUE(Added(c.ladder, "speed_scale"));
    EXPECT_LT(std::abs(c.ladder.rungs.back().fit.eg_rad_per_mps2 / c.run.eg_truth - 1), 0.01);
  }
  no_shift(Climb("training_only_gyro", 42, {"gyro_scale_pct=4"}, true));
  const Climbed skew = Climb("training_only_skew", 38, {"steer_delay_ms=40"}, true);
  EXPECT_NEAR(AppliedLatency(skew.ladder, config::Role::kSteeringWheelAngle), 0.040, 0.012);
  EXPECT_LT(std::abs(skew.ladder.rungs.back().fit.eg_rad_per_mps2 / skew.run.eg_truth - 1), 0.01);
}

}  // namespace
}  // namespace ndsid::testing
