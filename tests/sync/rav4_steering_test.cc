// The real RAV4 segment through config/rav4_2017.yaml: its steering angle is a role expression
// (STEER_ANGLE in 1.5-deg steps + STEER_FRACTION), checked against the coarse signal alone on the
// same frames. Skips with a message without the real-data folder.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "ndsid/can/frame_log.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/sync/role_extractor.h"

namespace ndsid::sync {
namespace {

struct Result {
  std::set<long> distinct_steps;  // steering values seen, in 0.01 deg
  double corr = 0;                // correlation of v * steering with the yaw rate while moving
  size_t samples = 0;
  double kin_gain = 0, kin_corr = 0;  // a_y against v * r (slope through the means, correlation)
  double mean_straight_yaw = 0;       // mean yaw rate while |v * steering| is small (straight)
  size_t straight = 0;
};

Result Replay(const config::Config& cfg) {
  const dbc::Database db = dbc::ParseDbcFile(cfg.dbc);
  RoleExtractor ex(cfg, db);
  SignalSync sync(cfg);
  auto log = can::OpenFrameLog(cfg.source.logs.at(0));
  std::vector<can::CanFrame> buf(256);
  std::vector<Sample> out;
  for (;;) {
    const auto r = log->Read(buf, 0);
    for (size_t i = 0; i < r.count; ++i) {
      sync.Advance(buf[i].timestamp_ns, out);
      ex.Process(buf[i], log->bus_names(), sync);
    }
    if (r.state == can::SourceState::kEnd) break;
  }
  sync.Flush(out);
  Result res;
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  double kx = 0, ky = 0, kxx = 0, kyy = 0, kxy = 0;
  size_t blocks = 0;
  for (const Sample& s : out) {
    if (!s.valid || !s.has_yaw_rate || s.speed_mps < 5) continue;
    res.distinct_steps.insert(std::lround(s.steer_rad * 180 / M_PI * 100));
    const double x = s.speed_mps * s.steer_rad, y = s.yaw_rate_radps;
    sx += x, sy += y, sxx += x * x, syy += y * y, sxy += x * y;
    if (std::abs(s.steer_rad) < 1.0 * M_PI / 180) {  // within 1 deg of the wheel's centre: straight
      res.mean_straight_yaw += s.yaw_rate_radps;
      ++res.straight;
    }
    ++res.samples;
  }
  const double n = static_cast<double>(res.samples);
  res.corr = (sxy - sx * sy / n) / std::sqrt((sxx - sx * sx / n) * (syy - sy * sy / n));
  if (res.straight) res.mean_straight_yaw /= static_cast<double>(res.straight);
  // a_y against v * (r - the straight-driving yaw rate), the gyro offset removed, in 1 s means
  // (the accelerometer carries road vibration: quasi-static relation, as the plausibility check).
  double block_vr = 0, block_a = 0;
  int in_block = 0;
  for (const Sample& s : out) {
    if (!s.valid || !s.has_yaw_rate || s.speed_mps < 5) continue;
    block_vr += s.speed_mps * (s.yaw_rate_radps - res.mean_straight_yaw);
    block_a += s.lat_accel_mps2;
    if (++in_block < 100) continue;
    const double vr = block_vr / in_block, a = block_a / in_block;
    kx += vr, ky += a, kxx += vr * vr, kyy += a * a, kxy += vr * a;
    ++blocks;
    block_vr = block_a = 0;
    in_block = 0;
  }
  const double nb = static_cast<double>(blocks);
  res.kin_gain = (kxy - kx * ky / nb) / (kxx - kx * kx / nb);
  res.kin_corr = (kxy - kx * ky / nb) / std::sqrt((kxx - kx * kx / nb) * (kyy - ky * ky / nb));
  return res;
}

// Catches: the RAV4 configuration back on the quantised coarse angle, or the sum not evaluated
// on the real frames (different from the coarse signal, explaining the yaw rate better).
TEST(Rav4Steering, FineAngleFromTheRoleExpression) {
  const std::string path = NDSID_SOURCE_DIR "/config/rav4_2017.yaml";
  config::Config cfg = config::LoadConfig(path);
  if (!std::filesystem::exists(cfg.dbc) || !std::filesystem::exists(cfg.source.logs.at(0)))
    GTEST_SKIP() << "skipped: real data not found (" << cfg.source.logs.at(0) << ")";
  auto& steer = cfg.roles[static_cast<int>(config::Role::kSteeringWheelAngle)];
  ASSERT_TRUE(steer && steer->expression) << "config/rav4_2017.yaml's steering is a role expression";
  const Result fine = Replay(cfg);
  steer->expression.reset();
  steer->inputs.clear();
  steer->expr.clear();
  steer->ref = {"STEER_ANGLE_SENSOR", "STEER_ANGLE"};
  const Result coarse = Replay(cfg);
  ASSERT_GT(fine.samples, 2000u);
  EXPECT_EQ(fine.samples, coarse.samples);
  // Interpolation between frames adds in-between values to both; the fraction adds many more.
  EXPECT_GT(fine.distinct_steps.size(), 2 * coarse.distinct_steps.size())
      << fine.distinct_steps.size() << " vs " << coarse.distinct_steps.size();
  EXPECT_GT(fine.corr, coarse.corr + 0.01) << fine.corr << " vs " << coarse.corr;
  // With the configured signs, a_y follows v * r (gain ~1: a_y positive to the
  // left after `sign: -1` on ACCEL_Y), and the yaw rate has an offset while driving straight.
  std::printf("RAV4 kinematics: a_y = %.3f * v*(r - r_straight) (1 s means, correlation %.3f); mean yaw rate driving straight %.3f deg/s over %zu samples\n",
              fine.kin_gain, fine.kin_corr, fine.mean_straight_yaw * 180 / M_PI, fine.straight);
  EXPECT_GT(fine.kin_gain, 0.8);
  EXPECT_LT(fine.kin_gain, 1.25);
  EXPECT_GT(fine.kin_corr, 0.7);
  std::printf("RAV4 steering: %zu distinct values (coarse %zu), corr(v*steer, r) %.3f (coarse %.3f), %zu samples\n",
              fine.distinct_steps.size(), coarse.distinct_steps.size(), fine.corr, coarse.corr, fine.samples);
}

}  // namespace
}  // namespace ndsid::sync
