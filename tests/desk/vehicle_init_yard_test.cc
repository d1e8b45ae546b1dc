// `ndsid init` on drives at walking pace with large steering angles (a yard, a car park: short
// drives of tight turns R 4.5-7 m, 300-650 deg at the steering wheel, simulated with
// road.parking_turns). The steering must be found from the kinematic relation, with its unit, sign
// and ratio, where hardly any sample has |a_y| above 2 m/s^2 or a speed above the estimator's gate.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <regex>
#include <string>

#include "ndsid/can/frame_log.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/sim/candump_writer.h"
#include "ndsid/sim/simulator.h"
#include "vehicle_init.h"

namespace ndsid::desk {
namespace {

namespace fs = std::filesystem;
using config::Role;

struct YardDrive {
  std::string log;
  double moving_s = 0, slow_share = 0, max_steer_deg = 0, high_ay_share = 0, steer_ratio = 0;
};

// Four drives of 0.3-0.8 km, each with 12 tight turns at each end, written as a candump log.
YardDrive SimulateYard(uint64_t seed, const dbc::Database& db) {
  config::SimulationConfig cfg;  // config/sim_cmax.yaml's defaults
  cfg.seed = seed;
  cfg.duration.drives = 4;
  cfg.duration.short_drive_fraction = 0;
  cfg.duration.min_km = 0.3;
  cfg.duration.max_km = 0.8;
  cfg.road.parking_turns = 12;
  YardDrive y;
  const fs::path dir = fs::path(NDSID_BINARY_DIR) / "tests" / "desk" / "vehicle_init_yard";
  fs::create_directories(dir);
  y.log = (dir / ("yard." + std::to_string(seed) + "." + std::to_string(::getpid()) + ".log")).string();
  sim::CandumpLogWriter writer(db, cfg, y.log);
  double slow = 0, high_ay = 0;
  sim::SimulateDrives(cfg, [&](sim::DriveResult&& d) {
    const sim::DriveSeries& s = d.series;
    y.steer_ratio = d.params.is;
    for (size_t i = 0; i < s.t_s.size(); ++i) {
      if (!(s.speed_mps[i] > 0.3)) continue;  // forward and moving
      y.moving_s += 1.0 / sim::kOutputRate_hz;
      slow += s.speed_mps[i] < 5.0;
      high_ay += std::fabs(s.a_y_mps2[i]) > 2.0;
      y.max_steer_deg = std::max(y.max_steer_deg, std::fabs(s.steer_sw_rad[i]) * 180.0 / M_PI);
    }
    writer.WriteDrive(d);
  });
  writer.Close();
  const double n = y.moving_s * sim::kOutputRate_hz;
  y.slow_share = slow / n;
  y.high_ay_share = high_ay / n;
  return y;
}

// The steer ratio init states for the unit it chose ("steer ratio with l = 2.65 m: 14.9 if deg").
double StatedSteerRatio(const RoleProposal& p) {
  const std::regex re("steer ratio with l = [0-9.]+ m: ([0-9.]+) if deg");
  std::smatch m;
  for (const std::string& e : p.evidence)
    if (std::regex_search(e, m, re)) return std::stod(m[1].str());
  return 0;
}

// Catches: a steering search that correlates only samples with |a_y| < 2 m/s^2 at speed, or that
// takes the kinematic relation only where the car is fast, failing (or choosing a wrong unit or
// sign) on a drive that is almost all walking pace and full lock.
TEST(InitInAYard, FindsTheSteeringOnDrivesAtWalkingPaceWithLargeAngles) {
  const dbc::Database db = dbc::ParseDbcFile(std::string(NDSID_SOURCE_DIR) + "/dbc/ndsid_example.dbc");
  for (uint64_t seed : {42u, 43u}) {
    const YardDrive y = SimulateYard(seed, db);
    std::printf("seed %llu: %.0f s moving, %.0f %% below 5 m/s, %.1f %% with |a_y| > 2 m/s^2, max %.0f deg\n",
                static_cast<unsigned long long>(seed), y.moving_s, 100 * y.slow_share, 100 * y.high_ay_share, y.max_steer_deg);
    // The drives are what they claim to be: walking pace and large angles dominate.
    ASSERT_GT(y.slow_share, 0.7) << seed;
    ASSERT_GT(y.max_steer_deg, 450) << seed;
    auto log = can::OpenFrameLog(y.log);
    InitOptions options;
    options.reference_wheelbase_m = 2.648;
    const InitResult r = ProposeVehicleConfig(db, *log, options);
    fs::remove(y.log);
    EXPECT_TRUE(r.MandatoryFound()) << seed;
    const RoleProposal* steer = r.Find(Role::kSteeringWheelAngle);
    ASSERT_NE(steer, nullptr);
    ASSERT_TRUE(steer->found) << steer->reason;
    EXPECT_EQ(steer->signal, "SteeringWheelAngle");
    EXPECT_EQ(steer->unit, "deg");
    EXPECT_EQ(steer->sign, 1);
    EXPECT_NEAR(StatedSteerRatio(*steer), y.steer_ratio, 0.03 * y.steer_ratio) << seed;  // the truth's ratio
  }
}

}  // namespace
}  // namespace ndsid::desk
