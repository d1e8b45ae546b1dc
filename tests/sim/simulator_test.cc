// Whole drives: the |a_y| distribution of the study, determinism, standstill on the crossfall,
// the closed driving loop staying in its lane, drive composition.
#include "ndsid/sim/simulator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace ndsid::sim {
namespace {

constexpr double kG = model::kGravity_mps2;

TEST(Simulator, LateralAccelDistributionMatchesStudyBands) {
  // Catches a driver/road mix that is too calm or too sporty for naturalistic driving: the study
  // (Reicherts 2021, sec. VI.B) reports ~75 % of |a_y| < 1, > 90 % < 2, > 99 % < 5 m/s^2.
  config::SimulationConfig cfg;
  cfg.seed = 3;
  cfg.duration.hours = 1.5;
  std::vector<double> ay;
  double hours = 0.0, km = 0.0, motorway_km = 0.0;
  int drives = 0;
  SimulateDrives(cfg, [&](DriveResult&& d) {
    ++drives;
    hours += d.stats.duration_s / 3600.0;
    km += d.stats.distance_km;
    motorway_km += d.stats.motorway_km;
    for (size_t i = 0; i < d.series.size(); ++i)
      if (std::fabs(d.series.speed_mps[i]) > 1.0) ay.push_back(std::fabs(d.series.a_y_meas_mps2[i]));
  });
  const double n = static_cast<double>(ay.size());
  auto below = [&](double a) { return std::count_if(ay.begin(), ay.end(), [a](double x) { return x < a; }) / n; };
  std::sort(ay.begin(), ay.end());
  std::printf("%d drives, %.2f h, %.0f km (%.0f %% motorway): |a_y| < 1: %.3f, < 2: %.3f, < 5: %.4f; "
              "q75 %.2f q90 %.2f q99 %.2f max %.2f m/s^2\n",
              drives, hours, km, 100.0 * motorway_km / km, below(1.0), below(2.0), below(5.0), ay[ay.size() * 3 / 4],
              ay[ay.size() * 9 / 10], ay[ay.size() * 99 / 100], ay.back());
  EXPECT_GT(below(1.0), 0.68);
  EXPECT_LT(below(1.0), 0.85);
  EXPECT_GT(below(2.0), 0.88);
  EXPECT_LT(below(2.0), 0.98);
  EXPECT_GT(below(5.0), 0.99);
  EXPECT_GT(ay.back(), 3.0);  // some rare sporty moments exist
  EXPECT_GE(hours, 1.5);
}

TEST(Simulator, SameSeedGivesIdenticalDrivesAndOtherSeedDoesNot) {
  // Catches hidden global state, uninitialised values or wall-clock dependence.
  config::SimulationConfig cfg;
  cfg.duration.drives = 2;
  cfg.seed = 21;
  const auto a = Simulate(cfg), b = Simulate(cfg);
  ASSERT_EQ(a.drives.size(), b.drives.size());
  for (size_t d = 0; d < a.drives.size(); ++d) {
    EXPECT_EQ(a.drives[d].start_epoch_ns, b.drives[d].start_epoch_ns);
    EXPECT_EQ(a.drives[d].series.a_y_meas_mps2, b.drives[d].series.a_y_meas_mps2);
    EXPECT_EQ(a.drives[d].series.steer_sw_meas_rad, b.drives[d].series.steer_sw_meas_rad);
    EXPECT_EQ(a.drives[d].series.speed_meas_mps, b.drives[d].series.speed_meas_mps);
  }
  cfg.seed = 22;
  const auto c = Simulate(cfg);
  EXPECT_NE(a.drives[0].series.a_y_meas_mps2.size(), c.drives[0].series.a_y_meas_mps2.size());
}

TEST(Simulator, StandstillReadsRoadCrossfall) {
  // Catches standstill samples that read zero instead of the road's cross-slope (study fig. 5).
  config::SimulationConfig cfg;
  cfg.duration.drives = 3;
  cfg.seed = 5;
  cfg.noise = {0, 0, 0, 0, 0, 0, 1.0};
  const auto r = Simulate(cfg);
  size_t standing = 0;
  double max_slope = 0.0;
  for (const auto& d : r.drives) {
    const auto& s = d.series;
    for (size_t i = 0; i < s.size(); ++i) {
      if (s.speed_mps[i] != 0.0) continue;
      ++standing;
      max_slope = std::max(max_slope, std::fabs(s.a_y_meas_mps2[i]));
      ASSERT_NEAR(s.a_y_meas_mps2[i], kG * std::sin(s.bank_rad[i]), 1e-9) << "drive " << d.index << " t " << s.t_s[i];
      ASSERT_EQ(s.speed_meas_mps[i], 0.0);
    }
  }
  EXPECT_GT(standing, 1000u);
  EXPECT_GT(max_slope, 0.02);  // crossfall is there
  EXPECT_LT(max_slope, kG * 0.031);
}

TEST(Simulator, DriverKeepsLaneAndCompletesDrives) {
  // Catches an unstable lateral controller, a stuck speed controller or drives that never end.
  config::SimulationConfig cfg;
  cfg.duration.drives = 6;
  cfg.seed = 8;
  int short_drives = 0;
  double prev_end_ns = 0.0;
  SimulateDrives(cfg, [&](DriveResult&& d) {
    const auto& s = d.series;
    double max_dev = 0.0;
    for (size_t i = 0; i < s.size(); ++i) {
      max_dev = std::max(max_dev, std::fabs(s.lateral_offset_m[i] - s.lane_target_m[i]));
    }
    EXPECT_GT(d.stats.distance_km, 0.3);
    EXPECT_LT(max_dev, 1.2) << "drive " << d.index;  // corner cutting in 10 m junction turns reaches ~0.85 m
    EXPECT_EQ(s.speed_mps.back(), 0.0) << "drive ends standing";
    short_drives += d.stats.distance_km < 2.0;
    if (d.index > 0) EXPECT_GT(static_cast<double>(d.start_epoch_ns) - prev_end_ns, 0.5 * 3600e9) << "key-off gap";
    prev_end_ns = static_cast<double>(d.start_epoch_ns) + d.stats.duration_s * 1e9;
    EXPECT_GT(d.stats.gated_fraction, 0.2);
    std::printf("drive %d: %.1f km, max |e_y - e_target| %.2f m\n", d.index, d.stats.distance_km, max_dev);
  });
  std::printf("short drives: %d of 6\n", short_drives);
}

TEST(Simulator, MassChangeShiftsSelfSteerGradientPerDrive) {
  // Catches a mass change that is not applied to the dynamics (EG ~ m): the quasi-steady
  // regression d_sw/is - l r/v = EG a_y on the true signals recovers each drive's EG.
  config::SimulationConfig cfg;
  cfg.duration.drives = 3;
  cfg.seed = 9;
  cfg.effects.mass_schedule_kg = {-250.0, 0.0, 300.0};
  const auto r = Simulate(cfg);
  const double eg0 = model::SelfSteerGradient(BaseParams(cfg.vehicle), cfg.vehicle.wheelbase_m);
  for (const auto& d : r.drives) {
    const double m = cfg.vehicle.mass_kg + cfg.effects.mass_schedule_kg[static_cast<size_t>(d.index) % 3];
    EXPECT_DOUBLE_EQ(d.params.m, m);
    EXPECT_NEAR(d.self_steer_gradient, eg0 * m / cfg.vehicle.mass_kg, 1e-12);
    const auto& s = d.series;
    double sxx = 0, sxy = 0;
    for (size_t i = 0; i < s.size(); ++i) {
      const double v = s.speed_mps[i];
      if (v < 8.0 || std::fabs(s.yaw_accel_radps2[i]) > 0.01 || std::fabs(s.a_y_mps2[i]) < 0.5) continue;
      const double a_kin = s.a_y_mps2[i];  // tyre forces / m: on a slope EG acts on the slope force too
      const double y = s.steer_sw_rad[i] / d.params.is - cfg.vehicle.wheelbase_m * s.yaw_rate_radps[i] / v;
      sxx += a_kin * a_kin;
      sxy += a_kin * y;
    }
    ASSERT_GT(sxx, 0.0);
    // Quasi-steady samples only; transients leave ~ a few per cent.
    std::printf("drive %d: m %.0f kg EG true %.4e fitted %.4e\n", d.index, m, d.self_steer_gradient, sxy / sxx);
    EXPECT_NEAR(sxy / sxx, d.self_steer_gradient, 0.05 * d.self_steer_gradient);
  }
}

}  // namespace
}  // namespace ndsid::sim
