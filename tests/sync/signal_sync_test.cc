#include "ndsid/sync/signal_sync.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ndsid::sync {
namespace {

using config::Role;

config::Config TestConfig() {
  return config::ParseConfig(R"(vehicle: {name: car, wheelbase_m: 2.6, mass_kg: 1500}
source: {type: log, logs: [a.log]}
dbc: b.dbc
signals:
  steering_wheel_angle: {message: M, signal: S, unit: rad, timeout_s: 0.1}
  vehicle_speed: {message: M, signal: V, unit: m/s, timeout_s: 0.1}
  lateral_acceleration: {message: M, signal: A, unit: m/s^2, timeout_s: 0.1}
  reverse_gear: {message: G, signal: R, timeout_s: 1.0}
  validity: [{message: M, signal: OK}]
sync: {rate_hz: 100, latency_s: 0.05, max_fill_gap_s: 1.0}
)", "t.yaml");
}

constexpr int64_t kMs = 1'000'000;

// Feeds linear ramps at 3 rates/phases (steering 100 Hz, speed 50 Hz offset 3 ms, a_y 80 Hz)
// from t0 to t1 [ms], advancing the clock as frames would.
void FeedRamps(SignalSync& s, std::vector<Sample>& out, int64_t t0, int64_t t1) {
  for (int64_t t = t0; t <= t1; ++t) {  // 1 ms steps
    s.Advance(t * kMs, out);
    if (t % 10 == 0) s.PushRole(Role::kSteeringWheelAngle, t * kMs, 0.001 * t);
    if (t % 20 == 3) s.PushRole(Role::kSpeed, t * kMs, 10.0 + 0.002 * t);
    if (t % 12 == 7) s.PushRole(Role::kLateralAcceleration, t * kMs, -0.5 + 0.0005 * t);
    if (t % 10 == 5) s.PushValidity(0, t * kMs, 1.0);
    if (t % 100 == 1) s.PushRole(Role::kReverseGear, t * kMs, 0.0);
  }
}

// Catches: interpolation that is off by a phase (a lag between roles is a fake time skew).
TEST(SignalSync, InterpolatesRampsExactlyOnTheGrid) {
  const auto cfg = TestConfig();
  SignalSync s(cfg);
  std::vector<Sample> out;
  FeedRamps(s, out, 1000, 3000);
  ASSERT_GT(out.size(), 150u);
  int checked = 0;
  for (const Sample& x : out) {
    const double t_ms = x.t_ns / 1e6;
    if (t_ms < 1100) continue;  // warm-up: every role seen at least once
    ASSERT_TRUE(x.valid) << t_ms;
    EXPECT_NEAR(x.steer_rad, 0.001 * t_ms, 1e-9);
    EXPECT_NEAR(x.speed_mps, 10.0 + 0.002 * t_ms, 1e-9);
    EXPECT_NEAR(x.lat_accel_mps2, -0.5 + 0.0005 * t_ms, 1e-9);
    EXPECT_EQ(x.t_ns % (10 * kMs), 0);
    ++checked;
  }
  EXPECT_GT(checked, 150);
  EXPECT_EQ(s.counters().invalid_samples, static_cast<uint64_t>(std::count_if(out.begin(), out.end(), [](const Sample& x) { return !x.valid; })));
}

// Catches: a silent sensor whose last value is held forever.
TEST(SignalSync, MarksSampleInvalidWhenRequiredRoleStale) {
  const auto cfg = TestConfig();
  SignalSync s(cfg);
  std::vector<Sample> out;
  for (int64_t t = 0; t <= 600; ++t) {
    s.Advance(t * kMs, out);
    if (t % 10 == 0 && t < 300) s.PushRole(Role::kSteeringWheelAngle, t * kMs, 0.1);  // stops at 300 ms
    if (t % 10 == 0) s.PushRole(Role::kSpeed, t * kMs, 10);
    if (t % 10 == 0) s.PushRole(Role::kLateralAcceleration, t * kMs, 0.2);
    if (t % 10 == 0) s.PushValidity(0, t * kMs, 1.0);
  }
  bool saw_valid = false, saw_stale = false;
  for (const Sample& x : out) {
    if (x.t_ns <= 290 * kMs && x.t_ns >= 50 * kMs) saw_valid |= x.valid;
    if (x.t_ns >= 400 * kMs) {
      EXPECT_FALSE(x.valid);
      EXPECT_TRUE(x.stale_roles & (1u << static_cast<int>(Role::kSteeringWheelAngle)));
      saw_stale = true;
    }
  }
  EXPECT_TRUE(saw_valid);
  EXPECT_TRUE(saw_stale);
}

TEST(SignalSync, ValidityFlagSaysInvalid) {
  const auto cfg = TestConfig();
  SignalSync s(cfg);
  std::vector<Sample> out;
  for (int64_t t = 0; t <= 400; ++t) {
    s.Advance(t * kMs, out);
    if (t % 10 == 0) {
      s.PushRole(Role::kSteeringWheelAngle, t * kMs, 0.1);
      s.PushRole(Role::kSpeed, t * kMs, 10);
      s.PushRole(Role::kLateralAcceleration, t * kMs, 0.2);
      s.PushValidity(0, t * kMs, t < 200 ? 1.0 : 0.0);
    }
  }
  for (const Sample& x : out) {
    if (x.t_ns >= 250 * kMs) EXPECT_TRUE(x.flags_invalid && !x.valid);
  }
}

// Catches: hours of key-off silence filled with millions of invalid samples, or a missing
// drive boundary.
TEST(SignalSync, DoesNotFillBusSilenceAndMarksTheGap) {
  const auto cfg = TestConfig();
  SignalSync s(cfg);
  std::vector<Sample> out;
  FeedRamps(s, out, 0, 500);
  const size_t before = out.size();
  FeedRamps(s, out, 3'600'000, 3'600'500);  // one hour later
  EXPECT_LT(out.size() - before, 60u);
  EXPECT_EQ(s.counters().gaps, 1u);
  const auto first_after = std::find_if(out.begin() + static_cast<long>(before), out.end(),
                                        [](const Sample& x) { return x.t_ns >= 3'600'000 * kMs; });
  ASSERT_NE(first_after, out.end());
  EXPECT_TRUE(first_after->gap_before);
}

// Catches: time going backwards corrupting the interpolation (it must be dropped and counted).
TEST(SignalSync, DropsAndCountsValuesGoingBackwardsAndNaN) {
  const auto cfg = TestConfig();
  SignalSync s(cfg);
  s.PushRole(Role::kSpeed, 100 * kMs, 10);
  s.PushRole(Role::kSpeed, 90 * kMs, 99);
  s.PushRole(Role::kSpeed, 110 * kMs, std::nan(""));
  EXPECT_EQ(s.counters().time_backwards, 1u);
  EXPECT_EQ(s.counters().non_finite, 1u);
}

// Catches: a configured latency ignored, applied with the wrong sign, or a shifted role
// going stale because the sync stage did not wait for it.
TEST(SignalSync, ConfiguredLatencyReadsTheRoleEarlier) {
  auto cfg = TestConfig();
  cfg.roles[static_cast<int>(Role::kSteeringWheelAngle)]->latency_s = 0.08;  // stamped 80 ms late
  SignalSync s(cfg);
  std::vector<Sample> out;
  FeedRamps(s, out, 1000, 3000);
  int checked = 0;
  for (const Sample& x : out) {
    const double t_ms = x.t_ns / 1e6;
    if (t_ms < 1100) continue;
    ASSERT_TRUE(x.valid) << t_ms;
    EXPECT_NEAR(x.steer_rad, 0.001 * (t_ms + 80), 1e-9) << t_ms;  // the value stamped 80 ms later
    EXPECT_NEAR(x.lat_accel_mps2, -0.5 + 0.0005 * t_ms, 1e-9);
    ++checked;
  }
  EXPECT_GT(checked, 150);
}

}  // namespace
}  // namespace ndsid::sync
