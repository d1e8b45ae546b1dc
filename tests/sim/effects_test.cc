// Every hidden effect changes the signals exactly as its equation in physics.md §4 says:
// effect-on vs effect-off runs with the same seed (the noise and driver streams are identical).
#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/sim/simulator.h"

namespace ndsid::sim {
namespace {

constexpr double kG = model::kGravity_mps2;

config::SimulationConfig Base() {
  config::SimulationConfig cfg;
  cfg.duration.drives = 2;
  cfg.seed = 77;
  return cfg;
}

struct Pair {
  SimulationResult off, on;
};
Pair RunPair(void (*set)(config::SimEffects&), config::SimulationConfig cfg = Base()) {
  Pair p{Simulate(cfg), {}};
  set(cfg.effects);
  p.on = Simulate(cfg);
  return p;
}

// Sensor-side effects leave the truth untouched.
void ExpectSameTruth(const Pair& p) {
  ASSERT_EQ(p.off.drives.size(), p.on.drives.size());
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    ASSERT_EQ(p.off.drives[d].series.a_y_mps2, p.on.drives[d].series.a_y_mps2);
    ASSERT_EQ(p.off.drives[d].series.steer_sw_rad, p.on.drives[d].series.steer_sw_rad);
  }
}

TEST(Effects, AccelBiasShiftsLateralAccelByBEverywhere) {
  // Catches a bias applied only while moving, or to the truth instead of the sensor.
  const auto p = RunPair([](config::SimEffects& e) { e.accel_bias_mps2 = 0.12; });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], 0.12, 1e-12);
  }
}

TEST(Effects, AccelScaleMultipliesTheCgAcceleration) {
  // Catches a scale applied to the truth, to the bias/noise terms, or in the wrong unit:
  // a_y,meas,on - a_y,meas,off = k_a a_y (2.5 %).
  const auto p = RunPair([](config::SimEffects& e) { e.accel_scale_pct = 2.5; });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 0; i < a.size(); ++i) ASSERT_NEAR(b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], 0.025 * a.a_y_mps2[i], 1e-12);
  }
}

TEST(Effects, AccelQuadraticBendsTheReadingTheSameWayInBothTurns) {
  // Catches a nonlinearity that is odd (a scale) instead of even, applied to the truth, or in the
  // wrong unit: a_y,meas,on - a_y,meas,off = k2 a_y^2 / g (-4 %), the same sign left and right.
  const auto p = RunPair([](config::SimEffects& e) { e.accel_quadratic_pct = -4.0; });
  ExpectSameTruth(p);
  double largest = 0;
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 0; i < a.size(); ++i) {
      const double ay = a.a_y_mps2[i];
      ASSERT_NEAR(b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], -0.04 * ay * ay / kG, 1e-12);
      largest = std::max(largest, std::fabs(ay));
    }
  }
  EXPECT_GT(largest, 2.0);  // the drives turn hard enough for the term to show
}

TEST(Effects, GyroOffsetAndScaleFollowTheirEquationEverywhere) {
  // Catches a gyro error applied to the truth, only while moving, or with the wrong unit:
  // r_meas,on - r_meas,off = k_r r + r0 (0.4 deg/s, 2 %), also at standstill.
  const auto p = RunPair([](config::SimEffects& e) {
    e.gyro_offset_degps = 0.4;
    e.gyro_scale_pct = 2.0;
  });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    ASSERT_EQ(a.yaw_rate_radps, b.yaw_rate_radps);
    for (size_t i = 0; i < a.size(); ++i)
      ASSERT_NEAR(b.yaw_rate_meas_radps[i] - a.yaw_rate_meas_radps[i], 0.02 * a.yaw_rate_radps[i] + 0.4 * M_PI / 180.0,
                  1e-12);
  }
}

TEST(Effects, VibrationAddsItsRmsAbove5MpsInThe15To35HzBandOnly) {
  // Catches a vibration of the wrong size, at standstill, outside its band, on the truth, or one
  // that shifts the other random streams: the difference on-off is the vibration alone, RMS 3 m/s^2
  // (a_y) and 1.5 deg/s (yaw) above 5 m/s, zero at standstill, and with no mean (it averages out
  // over 0.5 s, so a low-pass below 15 Hz removes it).
  const auto p = RunPair([](config::SimEffects& e) {
    e.accel_vibration_mps2 = 3;
    e.gyro_vibration_degps = 1.5;
  });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    ASSERT_EQ(a.speed_meas_mps, b.speed_meas_mps);
    ASSERT_EQ(a.steer_sw_meas_rad, b.steer_sw_meas_rad);
    double sa = 0, sr = 0, window_mean_max = 0;
    size_t n = 0;
    for (size_t i = 0; i < a.size(); ++i) {
      const double da = b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], dr = b.yaw_rate_meas_radps[i] - a.yaw_rate_meas_radps[i];
      // Fading out towards standstill: at most the tones' peak (2.83 x RMS) times v / 5 m/s.
      if (std::abs(a.speed_mps[i]) < 0.01) {
        ASSERT_LE(std::abs(da), 3 * 2.83 * std::abs(a.speed_mps[i]) / 5 + 1e-12);
        ASSERT_LE(std::abs(dr), 1.5 * M_PI / 180 * 2.83 * std::abs(a.speed_mps[i]) / 5 + 1e-12);
      }
      if (std::abs(a.speed_mps[i]) < 5) continue;
      sa += da * da;
      sr += dr * dr;
      ++n;
      if (i >= 50 && std::abs(a.speed_mps[i - 50]) >= 5) {
        double m = 0;
        for (size_t k = i - 49; k <= i; ++k) m += b.a_y_meas_mps2[k] - a.a_y_meas_mps2[k];
        window_mean_max = std::max(window_mean_max, std::abs(m / 50));
      }
    }
    ASSERT_GT(n, 5000u);  // more than 50 s above 5 m/s per drive
    EXPECT_NEAR(std::sqrt(sa / n), 3.0, 0.3) << d;
    EXPECT_NEAR(std::sqrt(sr / n) * 180 / M_PI, 1.5, 0.15) << d;
    EXPECT_LT(window_mean_max, 0.5) << d;  // 0.5 s means: a few percent of the RMS
  }
}

TEST(Effects, GyroAndAccelerometerLatenciesDelayWhatTheySense) {
  // Catches a latency applied to the truth, in the wrong direction (an advance), in the wrong unit,
  // or to the bias and noise: with the same noise draws r_meas,on - r_meas,off = r(t - tau) - r(t),
  // and the accelerometer's likewise (35 ms: between samples, linear interpolation; 60 ms: 6).
  const auto p = RunPair([](config::SimEffects& e) {
    e.gyro_delay_ms = 35.0;
    e.accel_delay_ms = 60.0;
  });
  ExpectSameTruth(p);
  double max_r = 0.0, max_a = 0.0;
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    ASSERT_EQ(a.yaw_rate_radps, b.yaw_rate_radps);
    for (size_t i = 10; i < a.size(); ++i) {
      const double r_35 = 0.5 * (a.yaw_rate_radps[i - 3] + a.yaw_rate_radps[i - 4]);
      ASSERT_NEAR(b.yaw_rate_meas_radps[i] - a.yaw_rate_meas_radps[i], r_35 - a.yaw_rate_radps[i], 1e-12) << i;
      ASSERT_NEAR(b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], a.a_y_mps2[i - 6] - a.a_y_mps2[i], 1e-12) << i;
      max_r = std::max(max_r, std::fabs(r_35 - a.yaw_rate_radps[i]));
      max_a = std::max(max_a, std::fabs(a.a_y_mps2[i - 6] - a.a_y_mps2[i]));
    }
  }
  EXPECT_GT(max_r, 0.005);  // the comparison is not between two constants
  EXPECT_GT(max_a, 0.1);
}

TEST(Effects, SteerOffsetShiftsMeasuredSteeringByD0) {
  // Catches an offset applied at the road wheel (/is) or in the wrong unit.
  const auto p = RunPair([](config::SimEffects& e) { e.steer_offset_deg = 1.5; });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 0; i < a.size(); ++i)
      ASSERT_NEAR(b.steer_sw_meas_rad[i] - a.steer_sw_meas_rad[i], 1.5 * M_PI / 180.0, 1e-12);
  }
}

TEST(Effects, LeverArmAddsXsTimesYawAcceleration) {
  // Catches a lever-arm term with the wrong sign or using the measured (noisy) yaw rate.
  const auto p = RunPair([](config::SimEffects& e) { e.lever_arm_m = 0.8; });
  ExpectSameTruth(p);
  double max_term = 0.0;
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 0; i < a.size(); ++i) {
      ASSERT_NEAR(b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], 0.8 * b.yaw_accel_radps2[i], 1e-12);
      max_term = std::max(max_term, std::fabs(0.8 * b.yaw_accel_radps2[i]));
    }
    // r' is the derivative of the recorded yaw rate (central difference, 100 Hz) where dynamic.
    for (size_t i = 1; i + 1 < b.size(); ++i) {
      if (std::fabs(b.speed_mps[i]) < 5.0) continue;
      const double fd = (b.yaw_rate_radps[i + 1] - b.yaw_rate_radps[i - 1]) / 0.02;
      ASSERT_NEAR(b.yaw_accel_radps2[i], fd, 0.01 + 0.02 * std::fabs(fd)) << "t " << b.t_s[i];
    }
  }
  EXPECT_GT(max_term, 0.1);
}

TEST(Effects, SteerDelayShiftsSteeringByDt) {
  // Catches a delay applied to the accelerometer instead, or rounded to the message cycle.
  const auto p = RunPair([](config::SimEffects& e) { e.steer_delay_ms = 50.0; });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 5; i < a.size(); ++i)  // 50 ms = 5 samples at 100 Hz
      ASSERT_NEAR(b.steer_sw_meas_rad[i] - a.steer_sw_meas_rad[i], b.steer_sw_rad[i - 5] - b.steer_sw_rad[i], 1e-12);
  }
}

TEST(Effects, SpeedScaleMultipliesMeasuredSpeed) {
  // Catches a scale error applied to the true speed (the dynamics) instead of the sensor.
  const auto p = RunPair([](config::SimEffects& e) { e.speed_scale_pct = 2.5; });
  ExpectSameTruth(p);
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    for (size_t i = 0; i < a.size(); ++i) {
      if (std::fabs(b.speed_mps[i]) < 1.0) continue;
      ASSERT_NEAR(b.speed_meas_mps[i] - a.speed_meas_mps[i], 0.025 * std::fabs(b.speed_mps[i]), 1e-12);
      ASSERT_NEAR(b.wheel_speed_meas_mps[2][i] - a.wheel_speed_meas_mps[2][i],
                  0.025 * std::fabs(b.speed_mps[i] - b.yaw_rate_radps[i] * 0.5 * Base().vehicle.track_width_m), 1e-12);
    }
  }
}

TEST(Effects, SpeedOffsetAndLatencyActOnTheSpeedSignalOnly) {
  // Catches an offset or latency applied to the true speed (the dynamics), to the wheel speeds,
  // at standstill, in the wrong unit or direction: with the same noise draws
  // v_meas,on - v_meas,off = |v(t - 200 ms)| - |v(t)| + 2 km/h while moving, 0 standing.
  const auto p = RunPair([](config::SimEffects& e) {
    e.speed_offset_kph = 2.0;
    e.speed_delay_ms = 200.0;
  });
  ExpectSameTruth(p);
  double max_lag = 0.0;
  size_t moving = 0, standing = 0;
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    ASSERT_EQ(a.speed_mps, b.speed_mps);
    for (int w = 0; w < 4; ++w) ASSERT_EQ(a.wheel_speed_meas_mps[w], b.wheel_speed_meas_mps[w]);
    for (size_t i = 20; i < a.size(); ++i) {  // 200 ms = 20 samples at 100 Hz
      const double v_then = std::fabs(a.speed_mps[i - 20]), v_now = std::fabs(a.speed_mps[i]);
      if (v_then > 1.0 && v_now > 1.0) {
        ASSERT_NEAR(b.speed_meas_mps[i] - a.speed_meas_mps[i], v_then - v_now + 2.0 / 3.6, 1e-9) << i;
        max_lag = std::max(max_lag, std::fabs(v_then - v_now));
        ++moving;
      } else if (v_then < 0.01 && v_now < 0.01) {
        ASSERT_EQ(b.speed_meas_mps[i], 0.0) << i;
        ++standing;
      }
    }
  }
  EXPECT_GT(max_lag, 0.3);  // the comparison is not between two constants
  EXPECT_GT(moving, 10000u);
  EXPECT_GT(standing, 100u);
}

TEST(Effects, RollAddsGTimesPhiFromTheRollOde) {
  // Catches roll without its own dynamics (phi = k a_y instantly) or with the wrong gain/sign.
  const auto p = RunPair([](config::SimEffects& e) { e.roll_gradient_deg_per_g = 6.0; });
  ExpectSameTruth(p);
  const double k = 6.0 * M_PI / 180.0 / kG, w = 2.0 * M_PI * 1.5, zeta = 0.5;
  for (size_t d = 0; d < p.on.drives.size(); ++d) {
    const auto &a = p.off.drives[d].series, &b = p.on.drives[d].series;
    double phi = 0.0, phi_dot = 0.0, err2 = 0.0, ref2 = 0.0, instant2 = 0.0;
    const double h = 0.001;
    for (size_t i = 0; i < a.size(); ++i) {
      ASSERT_NEAR(b.a_y_meas_mps2[i] - a.a_y_meas_mps2[i], kG * b.roll_rad[i], 1e-12);
      // Independent integration of phi'' = w^2 (k a_y - phi) - 2 zeta w phi' from the recorded a_y.
      err2 += (phi - b.roll_rad[i]) * (phi - b.roll_rad[i]);
      ref2 += b.roll_rad[i] * b.roll_rad[i];
      instant2 += (k * b.a_y_mps2[i] - b.roll_rad[i]) * (k * b.a_y_mps2[i] - b.roll_rad[i]);
      if (i + 1 < a.size())
        for (int s = 0; s < 10; ++s) {
          const double f = (s + 0.5) / 10.0;
          const double ay = b.a_y_mps2[i] + f * (b.a_y_mps2[i + 1] - b.a_y_mps2[i]);
          const double acc = w * w * (k * ay - phi) - 2.0 * zeta * w * phi_dot;
          phi_dot += h * acc;
          phi += h * phi_dot;
        }
    }
    std::printf("drive %zu: rms(phi - phi_ode)/rms(phi) %.2e, rms(phi - k a_y)/rms(phi) %.2e\n", d,
                std::sqrt(err2 / ref2), std::sqrt(instant2 / ref2));
    EXPECT_LT(std::sqrt(err2 / ref2), 0.01) << "drive " << d;
    EXPECT_LT(std::sqrt(err2), 0.2 * std::sqrt(instant2)) << "roll has dynamics, not an instant gain";
  }
}

TEST(Effects, SuperelevationBanksIntoCurvesInDynamicsAndOnAccelerometer) {
  // Catches a bank that acts only on the sensor (or only on the dynamics), or leans the wrong way.
  config::SimulationConfig cfg = Base();
  cfg.road.crossfall_pct_max = 0.0;  // isolate the superelevation
  cfg.effects.superelevation_pct = 6.0;
  cfg.duration.drives = 3;
  const auto r = Simulate(cfg);
  double with2 = 0.0, without2 = 0.0, corr = 0.0, max_bank = 0.0;
  size_t n = 0;
  for (const auto& d : r.drives) {
    const auto& s = d.series;
    for (size_t i = 1; i + 1 < s.size(); ++i) {
      corr += s.bank_rad[i] * s.curvature_1pm[i];
      max_bank = std::max(max_bank, std::fabs(s.bank_rad[i]));
      const double v = s.speed_mps[i];
      if (v < 5.0) continue;
      // Accelerometer = tyre forces/m = v (beta' + r) + g sin(theta) (gravity supports the turn).
      const double beta_dot = (s.side_slip_rad[i + 1] - s.side_slip_rad[i - 1]) / 0.02;
      const double kin = v * (beta_dot + s.yaw_rate_radps[i]);
      const double e_with = s.a_y_mps2[i] - kin - kG * std::sin(s.bank_rad[i]);
      const double e_without = s.a_y_mps2[i] - kin;
      with2 += e_with * e_with;
      without2 += e_without * e_without;
      ++n;
    }
  }
  ASSERT_GT(n, 1000u);
  std::printf("rms(a_y - v(beta'+r) - g sin theta) %.4f, without the bank term %.4f m/s^2, max bank %.2f %%\n",
              std::sqrt(with2 / n), std::sqrt(without2 / n), 100.0 * std::tan(max_bank));
  EXPECT_LT(std::sqrt(with2 / n), 0.02);
  EXPECT_GT(std::sqrt(without2 / n), 3.0 * std::sqrt(with2 / n));
  EXPECT_NEAR(std::tan(max_bank), 0.06, 1e-6);
  EXPECT_LT(corr, 0.0) << "bank into the curve: theta opposite to the curvature";
}

TEST(Effects, TyreSaturationOnlyMattersAtHighLateralAccel) {
  // Catches saturation that already bends the low-a_y range (the study: linear below ~4 m/s^2).
  config::SimulationConfig cfg = Base();
  cfg.effects.tyre_mu = 0.9;
  const auto on = Simulate(cfg);
  for (const auto& d : on.drives) {
    const auto& s = d.series;
    for (size_t i = 0; i < s.size(); ++i) {
      if (s.speed_mps[i] < 5.0 || std::fabs(s.yaw_accel_radps2[i]) > 0.01) continue;
      // quasi-steady: d_sw/is - l r/v = EG a_y within the tanh correction (1 - x^2/3 ~ 1.5 % at 2 m/s^2)
      const double y = s.steer_sw_rad[i] / d.params.is - 2.648 * s.yaw_rate_radps[i] / s.speed_mps[i];
      if (std::fabs(s.a_y_mps2[i]) < 1.0) EXPECT_NEAR(y, d.self_steer_gradient * s.a_y_mps2[i], 2e-3);
    }
  }
}

}  // namespace
}  // namespace ndsid::sim
