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

// Feeds linear ramps (steering 100 Hz, speed 50 Hz offset 3 ms) and a_y where `a_y` gives a value
// at t [ms] (NaN: no frame), from t0 to t1 [ms], advancing the clock as frames would.
template <typename AyAt>
void Feed(SignalSync& s, std::vector<Sample>& out, int64_t t0, int64_t t1, AyAt a_y) {
  for (int64_t t = t0; t <= t1; ++t) {  // 1 ms steps
    s.Advance(t * kMs, out);
    if (t % 10 == 0) s.PushRole(Role::kSteeringWheelAngle, t * kMs, 0.001 * t);
    if (t % 20 == 3) s.PushRole(Role::kSpeed, t * kMs, 10.0 + 0.002 * t);
    if (const double a = a_y(t); !std::isnan(a)) s.PushRole(Role::kLateralAcceleration, t * kMs, a);
    if (t % 10 == 5) s.PushValidity(0, t * kMs, 1.0);
    if (t % 100 == 1) s.PushRole(Role::kReverseGear, t * kMs, 0.0);
  }
}

// The ramps with a_y at 80 Hz (every 12 ms, offset 7 ms).
void FeedRamps(SignalSync& s, std::vector<Sample>& out, int64_t t0, int64_t t1) {
  Feed(s, out, t0, t1, [](int64_t t) { return t % 12 == 7 ? -0.5 + 0.0005 * static_cast<double>(t) : NAN; });
}

// Catches: a role slower than the sync latency held at its older value instead of interpolated
// (a zero-order hold lags it by up to a cycle: a fake time skew that biased EG by +2.4 % with a
// 12.5 Hz IMU message). The lateral acceleration comes every 80 ms with every third frame lost
// (gaps of 160 ms, within its 0.3 s timeout); the grid waits for it and reproduces its ramp.
TEST(SignalSync, WaitsForASlowIrregularRoleWithinItsTimeout) {
  config::Config cfg = TestConfig();
  cfg.roles[static_cast<int>(Role::kLateralAcceleration)]->timeout_s = 0.3;
  SignalSync s(cfg);
  std::vector<Sample> out;
  int a_frames = 0;
  Feed(s, out, 1000, 4000, [&](int64_t t) {
    return t % 80 == 7 && ++a_frames % 3 != 0 ? -0.5 + 0.0005 * static_cast<double>(t) : NAN;
  });
  int checked = 0;
  for (const Sample& x : out) {
    const double t_ms = x.t_ns / 1e6;
    if (t_ms < 1200) continue;
    ASSERT_TRUE(x.valid) << t_ms;
    EXPECT_NEAR(x.lat_accel_mps2, -0.5 + 0.0005 * t_ms, 1e-9) << t_ms;
    EXPECT_NEAR(x.steer_rad, 0.001 * t_ms, 1e-9) << t_ms;
    ++checked;
  }
  EXPECT_GT(checked, 250);
  // Intervals of 80 and 160 ms in turn (every third frame lost): 120 ms on average.
  EXPECT_NEAR(s.MeanInterval_s(Role::kLateralAcceleration), 0.120, 0.002);
  EXPECT_NEAR(s.MeanInterval_s(Role::kSteeringWheelAngle), 0.010, 1e-6);
  EXPECT_EQ(s.MeanInterval_s(Role::kYawRate), 0.0);  // never seen
}

// Catches: a wait for a very slow role (every 2 s, timeout 3 s) that outlasts the fast roles'
// history, which would leave them nothing to interpolate from: the grid then goes on with the
// slow role held, every sample valid and the fast ramps exact.
TEST(SignalSync, AWaitNeverOutlastsTheFastRolesHistory) {
  config::Config cfg = TestConfig();
  cfg.roles[static_cast<int>(Role::kLateralAcceleration)]->timeout_s = 3.0;
  SignalSync s(cfg);
  std::vector<Sample> out;
  Feed(s, out, 1000, 12000, [](int64_t t) { return t % 2000 == 7 ? 1.0 : NAN; });
  int checked = 0;
  for (const Sample& x : out) {
    const double t_ms = x.t_ns / 1e6;
    if (t_ms < 2100) continue;
    ASSERT_TRUE(x.valid) << t_ms;
    EXPECT_NEAR(x.steer_rad, 0.001 * t_ms, 1e-9) << t_ms;
    EXPECT_NEAR(x.lat_accel_mps2, 1.0, 1e-12) << t_ms;
    ++checked;
  }
  EXPECT_GT(checked, 800);  // 2.1 s .. about 10.7 s (the last 1.3 s wait for the slow role or the end)
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

namespace ndsid::sync {
namespace {

// Catches: a filter whose delay is not the one the sync stage takes back (a fake time skew of
// the conditioned role against the others), or one that does not remove vibration.
TEST(BesselLowPass, UnitDcGainCutoffAtThreeDecibelsAndFlatDelay) {
  const BesselLowPass f(5.0, 100.0);
  EXPECT_NEAR(f.Gain(0.0), 1.0, 1e-12);
  EXPECT_NEAR(f.Gain(5.0), std::sqrt(0.5), 1e-6);
  EXPECT_LT(f.Gain(25.0), 0.12);
  EXPECT_NEAR(f.delay_s(), 1.3616541287161306 / (2 * M_PI * 5.0), 0.004);  // the analogue's 1/w0
  // The delay of a 1 Hz sine through the filter (its zero crossings) is the DC delay within 1 ms.
  BesselLowPass g(5.0, 100.0);
  double last_y = 0, crossing = -1;
  for (int k = 0; k < 1000; ++k) {
    const double t = k / 100.0;
    const double y = g.Step(std::sin(2 * M_PI * 1.0 * t));
    if (k > 200 && last_y < 0 && y >= 0 && crossing < 0) crossing = (k - 1 + (-last_y) / (y - last_y)) / 100.0;
    last_y = y;
  }
  ASSERT_GT(crossing, 0);
  const double delay = crossing - std::round(crossing);  // the sine crosses upward at whole seconds
  EXPECT_NEAR(delay, f.delay_s(), 0.001);
  EXPECT_THROW(BesselLowPass(30.0, 100.0), Error);
  EXPECT_THROW(BesselLowPass(0.0, 100.0), Error);
}

TEST(SignalSync, LowPassedRoleStaysAlignedAndLosesItsVibration) {
  auto cfg = TestConfig();
  cfg.roles[static_cast<int>(Role::kLateralAcceleration)]->lowpass_hz = 5.0;
  SignalSync s(cfg);
  std::vector<Sample> out;
  auto truth = [](double t_s) { return 2.0 * std::sin(2 * M_PI * 0.4 * t_s); };
  for (int64_t t = 0; t <= 20000; ++t) {  // 1 ms steps, every role at 100 Hz
    s.Advance(t * kMs, out);
    if (t % 10 != 0) continue;
    const double ts = t * 1e-3;
    s.PushRole(Role::kSteeringWheelAngle, t * kMs, 0.1);
    s.PushRole(Role::kSpeed, t * kMs, 10);
    s.PushRole(Role::kLateralAcceleration, t * kMs, truth(ts) + 3.0 * std::sin(2 * M_PI * 23.0 * ts + 0.3));
    s.PushValidity(0, t * kMs, 1.0);
  }
  double worst = 0;
  int n = 0;
  for (const Sample& x : out) {
    if (x.t_ns < 2000 * kMs || !x.valid) continue;
    worst = std::max(worst, std::abs(x.lat_accel_mps2 - truth(x.t_ns * 1e-9)));
    ++n;
  }
  ASSERT_GT(n, 1500);
  // Vibration of 3 m/s^2 at 23 Hz down to < 0.2; the 0.4 Hz signal's residual phase and gain
  // error is < 1 %: about 0.02 at 2 m/s^2.
  EXPECT_LT(worst, 0.2);
}

}  // namespace
}  // namespace ndsid::sync
