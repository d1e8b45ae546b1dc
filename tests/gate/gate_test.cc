#include "ndsid/gate/gate.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ndsid::gate {
namespace {

constexpr int64_t kPeriod = 10'000'000;  // 100 Hz

sync::Sample Moving(int64_t k, double v = 20, double ay = 1.0) {
  sync::Sample s;
  s.t_ns = k * kPeriod;
  s.speed_mps = v;
  s.lat_accel_mps2 = ay;
  s.steer_rad = 0.05;
  s.valid = true;
  return s;
}

// Catches: a rejection reason not counted, or counted under the wrong name.
TEST(Gate, CountsEachRejectionReason) {
  Gate g(config::GateConfig{}, 0.01);
  int64_t k = 0;
  auto run = [&](sync::Sample s) { s.t_ns = (k++) * kPeriod; return g.Process(s).verdict; };
  EXPECT_EQ(run(Moving(0)), Verdict::kAccepted);
  auto invalid = Moving(0);
  invalid.valid = false;
  EXPECT_EQ(run(invalid), Verdict::kInvalidSignal);
  auto rev = Moving(0);
  rev.reverse = true;
  EXPECT_EQ(run(rev), Verdict::kReverse);
  auto esc = Moving(0);
  esc.esc_active = true;
  EXPECT_EQ(run(esc), Verdict::kEscIntervention);
  EXPECT_EQ(run(Moving(0, 4.0)), Verdict::kBelowMinSpeed);
  EXPECT_EQ(run(Moving(0, 20, -4.5)), Verdict::kNonlinearRange);
  const auto& c = g.counters();
  for (Verdict v : {Verdict::kAccepted, Verdict::kInvalidSignal, Verdict::kReverse, Verdict::kEscIntervention,
                    Verdict::kBelowMinSpeed, Verdict::kNonlinearRange}) {
    EXPECT_EQ(c.by_verdict[static_cast<int>(v)], 1u) << VerdictName(v);
  }
}

// Catches: the cross-slope diagnostic subtracted or lost; a brief slow-down called standstill.
TEST(Gate, StandstillAfterOneSecondKeepsCrossSlopeDiagnostic) {
  Gate g(config::GateConfig{}, 0.01);
  int standstill = 0;
  for (int64_t k = 0; k < 300; ++k) {
    const auto r = g.Process(Moving(k, 0.0, 0.25));  // stopped on a 2.5 % cross-slope
    if (r.verdict == Verdict::kStandstill) ++standstill;
    else EXPECT_EQ(r.verdict, Verdict::kBelowMinSpeed);
  }
  EXPECT_EQ(standstill, 200);  // the first second is not yet standstill
  EXPECT_NEAR(g.standstill().mean_mps2(), 0.25, 1e-12);
}

// Catches: drives not split at key cycles; distance not integrated (the 2 km rule needs it).
TEST(Gate, NewDriveAfterBusGapAndDistanceIntegrates) {
  Gate g(config::GateConfig{}, 0.01);
  GatedSample last;
  for (int64_t k = 0; k < 1000; ++k) last = g.Process(Moving(k, 20));
  EXPECT_EQ(last.drive_id, 0);
  EXPECT_NEAR(last.drive_distance_m, 200.0, 0.5);  // 10 s at 20 m/s
  auto after = Moving(1000 + 100 * 60 * 10, 20);   // 10 minutes later
  after.gap_before = true;
  const auto r = g.Process(after);
  EXPECT_TRUE(r.new_drive);
  EXPECT_EQ(r.drive_id, 1);
  EXPECT_LT(r.drive_distance_m, 1.0);
  EXPECT_EQ(g.counters().drives, 2u);
}

// Catches: quasi-steady flag set while steering moves (biases the steady-state EG).
TEST(Gate, QuasiSteadyOnlyWhenSteeringIsStill) {
  Gate g(config::GateConfig{}, 0.01);
  int steady_hold = 0, steady_ramp = 0;
  for (int64_t k = 0; k < 200; ++k) steady_hold += g.Process(Moving(k)).quasi_steady;
  for (int64_t k = 200; k < 400; ++k) {
    auto s = Moving(k);
    s.steer_rad = 0.05 + 0.5 * (k - 200) * 0.01;  // 0.5 rad/s
    steady_ramp += g.Process(s).quasi_steady;
  }
  EXPECT_GT(steady_hold, 190);
  EXPECT_LT(steady_ramp, 10);
}

}  // namespace
}  // namespace ndsid::gate

namespace ndsid::gate {
namespace {

// Catches: stops merged across a drive boundary or a drive on, their means taken over the
// samples before the standstill rule held, or the yaw rate's mean lost (the gyro offset).
TEST(Gate, StandstillStopsCarryTheirMeans) {
  Gate g(config::GateConfig{}, 0.01);
  int64_t k = 0;
  auto feed = [&](int n, double v, double ay, double r, bool yaw = true) {
    for (int i = 0; i < n; ++i) {
      sync::Sample s = Moving(k++, v, ay);
      s.has_yaw_rate = yaw;
      s.yaw_rate_radps = r;
      g.Process(s);
    }
  };
  feed(500, 20, 1.0, 0.05);
  feed(400, 0.0, 0.2, 0.007);   // first stop: 1 s before the standstill rule, then 3 s counted
  feed(500, 20, 1.0, 0.05);
  feed(300, 0.0, -0.1, 0.008, false);  // second stop, no yaw rate
  k += 10000;                          // a bus silence: the drive ends (the stop has ended too)
  feed(200, 0.0, 0.3, -0.002);         // a stop at the start of the next drive, ended by Finish
  g.Finish();
  const auto stops = g.TakeStops();
  ASSERT_EQ(stops.size(), 3u);
  EXPECT_EQ(stops[0].drive_id, 0);
  EXPECT_EQ(stops[0].samples, 300u);
  EXPECT_NEAR(stops[0].seconds, 3.0, 1e-9);
  EXPECT_NEAR(stops[0].mean_lat_accel_mps2, 0.2, 1e-12);
  EXPECT_NEAR(stops[0].mean_yaw_rate_radps, 0.007, 1e-12);
  EXPECT_EQ(stops[1].samples, 200u);
  EXPECT_NEAR(stops[1].mean_lat_accel_mps2, -0.1, 1e-12);
  EXPECT_TRUE(std::isnan(stops[1].mean_yaw_rate_radps));
  EXPECT_EQ(stops[2].drive_id, 1);
  EXPECT_EQ(stops[2].samples, 100u);
  EXPECT_NEAR(stops[2].mean_yaw_rate_radps, -0.002, 1e-12);
  EXPECT_TRUE(g.TakeStops().empty()) << "taken once";
}

}  // namespace
}  // namespace ndsid::gate
