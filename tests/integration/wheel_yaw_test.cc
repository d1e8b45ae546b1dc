// The yaw reference from the rear wheels (stats/wheel_yaw.h) on simulated drives: the gyro's
// scale against (v_RR - v_RL)/t is recovered within its stated standard error and tolerance,
// whatever the accelerometer's scale, with the speed's scale in the wheels (s = (1 + k_r)/(1 + eps)),
// and with the rolling radii differing left to right and falling with lateral load.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "ndsid/stats/wheel_yaw.h"
#include "sim_harness.h"

namespace ndsid::testing {
namespace {

constexpr double kHours = 0.5;

stats::WheelYawEvidence Measure(const std::string& name, uint64_t seed, const std::vector<std::string>& effects) {
  SimulatedRun run = SimulateAndReplay("wheel_yaw_" + name + std::to_string(seed), seed, kHours, effects);
  std::vector<const stats::Segment*> all(run.window.training.begin(), run.window.training.end());
  all.insert(all.end(), run.window.validation.begin(), run.window.validation.end());
  const stats::WheelYawEvidence ev = stats::EstimateWheelYawScale(all, run.config->vehicle.track_rear_m);
  std::printf("%s seed %llu: %s\n", name.c_str(), static_cast<unsigned long long>(seed), ev.note.c_str());
  return ev;
}

// |measured - expected| within 3 standard errors plus 0.2 % (the regression's small-sample and
// sync-interpolation bias, measured on clean drives below 0.1 %).
void ExpectScale(const stats::WheelYawEvidence& ev, double expected, const std::string& what) {
  ASSERT_TRUE(ev.available) << what << ": " << ev.note;
  EXPECT_LT(ev.se, 0.01) << what << ": " << ev.note;
  EXPECT_LE(std::abs(ev.scale - expected), 3 * ev.se + 0.002) << what << ": expected " << expected << ", " << ev.note;
}

// Catches: a gyro scale that the wheel reference misses or halves.
TEST(WheelYaw, AGyroScaleIsMeasuredAgainstTheRearWheels) {
  ExpectScale(Measure("gyro+3", 401, {"gyro_scale_pct=3"}), 0.03, "gyro +3 %");
  ExpectScale(Measure("gyro-2", 402, {"gyro_scale_pct=-2"}), -0.02, "gyro -2 %");
}

// Catches: an accelerometer scale leaking into the gyro's (a_y is only the instrument), or a
// clean gyro read as scaled.
TEST(WheelYaw, AnAccelerometerScaleAndCleanDataReadNoGyroScale) {
  ExpectScale(Measure("accel+3", 403, {"accel_scale_pct=3"}), 0.0, "accel +3 %");
  ExpectScale(Measure("clean", 404, {}), 0.0, "clean");
}

// Catches: the wheels' own scale ignored: a speed scale eps reads s = 1/(1 + eps).
TEST(WheelYaw, TheWheelsCarryTheSpeedScale) {
  ExpectScale(Measure("speed+2", 405, {"speed_scale_pct=2"}), 1 / 1.02 - 1, "speed +2 %");
}

// Catches: a rolling-radius difference or its fall with load biasing the scale (the load term
// grows with v^2 against r t and would read as a scale at highway speeds). A rear right tyre
// whose radius is d above the left's reads v/(1 + d): the pair's mean scale, which the reference
// carries like the speed's, falls to (1 + 1/(1 + d))/2, and s = (1 + k_r) over that.
TEST(WheelYaw, RollingRadiusDifferencesAndLoadAreSeparated) {
  const auto pair_scale = [](double d) { return (1 + 1 / (1 + d)) / 2; };
  const stats::WheelYawEvidence a = Measure("radius", 406, {"gyro_scale_pct=2", "rear_wheel_radius_diff_pct=0.8",
                                                            "wheel_radius_load_pct_per_g=0.5"});
  ExpectScale(a, 1.02 / pair_scale(0.008) - 1, "gyro +2 % with radius differences");
  EXPECT_NEAR(a.radius_diff, 1 / 1.008 - 1, 0.001) << a.note;
  EXPECT_NEAR(a.load_per_g, 2 * 0.005, 0.002) << a.note;  // both sides: 2 c
  const stats::WheelYawEvidence b = Measure("radius-", 407, {"rear_wheel_radius_diff_pct=-0.8", "wheel_radius_load_pct_per_g=1"});
  ExpectScale(b, 1 / pair_scale(-0.008) - 1, "clean gyro with radius differences");
  EXPECT_NEAR(b.radius_diff, 1 / 0.992 - 1, 0.001) << b.note;
  EXPECT_NEAR(b.load_per_g, 2 * 0.01, 0.002) << b.note;
}

}  // namespace
}  // namespace ndsid::testing
