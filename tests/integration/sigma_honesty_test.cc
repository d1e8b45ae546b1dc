// sigma(EG) honesty on the real-drive conditions the simulator reproduces (docs/accuracy.md,
// "sigma on slow, irregular and vibrating buses"): 20 seeds, both outputs, alternating between
// an IMU message at 12.5 Hz with 15 % of every message's frames lost and an IMU vibrating at
// 15-35 Hz conditioned by lowpass_hz 5. Under an honest sigma about 95 % of the errors lie
// within 2 sigma and their mean z is near 0; no estimate is valid with EG off by more than 2 %.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim_harness.h"

namespace ndsid::testing {
namespace {

// Catches: a sigma that holds on clean drives but not where the bus is slow and irregular or the
// sensor vibrates (the interpolation's smoothing and the low-pass's residual ripple left out of it).
TEST(SigmaHonesty, SigmaCoversEgOnSlowIrregularAndVibratingBuses) {
  int within = 0, n = 0, not_valid = 0;
  double sum_z = 0;
  for (int seed = 400; seed < 420; ++seed) {
    const bool slow = seed % 2 == 0;
    ReplayTweaks t{.identify_every_s = 0, .mass_schedule_kg = {}, .yaw_rate_output = true};
    std::vector<std::string> effects;
    if (slow) {
      t.message_cycle_ms = {{"ESP_DYNAMICS", 80}};
      t.frame_loss_pct = 15;
      t.timeout_s = 0.5;
    } else {
      effects = {"accel_vibration_mps2=3", "gyro_vibration_degps=1.5"};
      t.lowpass_hz = 5;
    }
    SimulatedRun run = SimulateAndReplay("sigma_honesty_" + std::to_string(seed), seed, 0.7, effects, {"road_bank", "gyro_offset"}, t);
    const pipeline::Estimate& e = run.pipeline->IdentifyNow(true);
    const double truth = model::EgToDegPerG(run.eg_truth);
    const double z = e.fit.eg_se_deg_per_g > 0 ? (e.fit.eg_deg_per_g - truth) / e.fit.eg_se_deg_per_g : INFINITY;
    std::printf("%s seed %d: EG %.4f +- %.4f deg/g (truth %.4f), z %+.2f, %s%s\n", slow ? "slow bus " : "vibration", seed,
                e.fit.eg_deg_per_g, e.fit.eg_se_deg_per_g, truth, z, e.fit.valid ? "valid" : "not valid: ",
                e.fit.valid ? "" : e.fit.reason.substr(0, 160).c_str());
    if (!e.fit.valid) {
      ++not_valid;
      continue;
    }
    EXPECT_LT(std::abs(e.fit.eg_deg_per_g / truth - 1), 0.02) << seed;
    within += std::abs(z) <= 2 ? 1 : 0;
    sum_z += z;
    ++n;
  }
  std::printf("valid %d of 20; within 2 sigma: %d of %d; mean z %+.2f\n", n, within, n, n ? sum_z / n : 0.0);
  // The conditions are fit for identification: at least 3 of 4 seeds valid. Measured 20 of 20.
  // Before the steady-state regression averaged its stretches, one vibrating seed failed
  // steady_state (3.20 +- 0.00 deg/g against a fit 0.18 % from the truth); before the slow roles'
  // floors were scaled, two slow-bus seeds failed explained_a_y.
  EXPECT_LE(not_valid, 5);
  ASSERT_GT(n, 0);
  EXPECT_GE(within, n - 3) << "of " << n;                  // 95 %: P(more than 3 of 20 beyond 2 sigma) ~ 1.6 %
  EXPECT_LT(std::abs(sum_z / n), 3 / std::sqrt(static_cast<double>(n)));  // 3 se of a mean of n unit normals
}

}  // namespace
}  // namespace ndsid::testing
