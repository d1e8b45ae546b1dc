// The simulator's YAML and --effect parsing: defaults = config/sim_cmax.yaml, errors with places.
#include "ndsid/config/simulation_config.h"

#include <gtest/gtest.h>

#include "ndsid/common/error.h"

namespace ndsid::config {
namespace {

TEST(SimulationConfig, ShippedCmaxYamlEqualsBuiltInDefaults) {
  // Catches the documented config and the code's defaults drifting apart.
  const auto c = LoadSimulationConfig(std::string(NDSID_SOURCE_DIR) + "/config/sim_cmax.yaml");
  const SimulationConfig d;
  EXPECT_EQ(c.seed, d.seed);
  EXPECT_EQ(c.vehicle.mass_kg, d.vehicle.mass_kg);
  EXPECT_EQ(c.vehicle.yaw_inertia_kgm2, d.vehicle.yaw_inertia_kgm2);
  EXPECT_EQ(c.vehicle.cornering_stiffness_front_npr, d.vehicle.cornering_stiffness_front_npr);
  EXPECT_EQ(c.vehicle.cornering_stiffness_rear_npr, d.vehicle.cornering_stiffness_rear_npr);
  EXPECT_EQ(c.vehicle.cg_to_front_m, d.vehicle.cg_to_front_m);
  EXPECT_EQ(c.vehicle.wheelbase_m, d.vehicle.wheelbase_m);
  EXPECT_EQ(c.vehicle.steering_ratio, d.vehicle.steering_ratio);
  EXPECT_EQ(c.noise.lat_accel_mps2, d.noise.lat_accel_mps2);
  EXPECT_EQ(c.drivers.lat_accel_comfort_max_mps2, d.drivers.lat_accel_comfort_max_mps2);
  EXPECT_EQ(c.integration.step_hz, d.integration.step_hz);
  EXPECT_EQ(c.duration.hours, d.duration.hours);
  EXPECT_EQ(c.road.parking_turns, d.road.parking_turns);
  EXPECT_FALSE(c.effects.any());
}

TEST(SimulationConfig, UnknownKeyIsRejectedWithLine) {
  // Catches typos in effect names silently ignored (an effect the user believes is on).
  try {
    ParseSimulationConfig("seed: 3\neffects:\n  steer_ofset_deg: 1.5\n", "x.yaml");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("x.yaml:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("effects.steer_ofset_deg"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseSimulationConfig("vehicle:\n  mass_kg: heavy\n", "x.yaml"), ConfigError);
  EXPECT_THROW(ParseSimulationConfig("effects:\n  tyre_mu: -1\n", "x.yaml"), ConfigError);
  EXPECT_EQ(ParseSimulationConfig("road:\n  parking_turns: 3\n", "x.yaml").road.parking_turns, 3);
  EXPECT_THROW(ParseSimulationConfig("road:\n  parking_turns: 21\n", "x.yaml"), ConfigError);
  EXPECT_THROW(ParseSimulationConfig("road:\n  parking_turns: -1\n", "x.yaml"), ConfigError);
  EXPECT_THROW(ParseSimulationConfig("road:\n  parking_turns: 2.5\n", "x.yaml"), ConfigError);
  EXPECT_EQ(ParseSimulationConfig("effects:\n  steer_deadband_deg: -1\n", "x.yaml").effects.steer_deadband_deg, -1.0);
  EXPECT_THROW(ParseSimulationConfig("effects:\n  steer_deadband_deg: -31\n", "x.yaml"), ConfigError);
  EXPECT_THROW(ParseSimulationConfig("effects:\n  steer_asymmetry_pct: 40\n", "x.yaml"), ConfigError);
  EXPECT_EQ(ParseSimulationConfig("effects:\n  steer_asymmetry_pct: -4\n", "x.yaml").effects.steer_asymmetry_pct, -4.0);
  EXPECT_THROW(ParseSimulationConfig("effects:\n  accel_quadratic_pct: 31\n", "x.yaml"), ConfigError);
  EXPECT_EQ(ParseSimulationConfig("effects:\n  accel_quadratic_pct: -3\n", "x.yaml").effects.accel_quadratic_pct, -3.0);
  const auto c = ParseSimulationConfig("effects:\n  steer_offset_deg: 1.5\n  mass_schedule_kg: [0, 150]\n", "x.yaml");
  EXPECT_EQ(c.effects.steer_offset_deg, 1.5);
  EXPECT_EQ(c.effects.mass_schedule_kg.size(), 2u);
}

TEST(SimulationConfig, EffectAssignmentParsesNameAndValue) {
  // Catches --effect silently accepting unknown names or junk values.
  SimEffects e;
  ApplyEffect(e, "steer_offset_deg=1.5");
  ApplyEffect(e, "lever_arm_m=-0.8");
  EXPECT_EQ(e.steer_offset_deg, 1.5);
  EXPECT_EQ(e.lever_arm_m, -0.8);
  EXPECT_TRUE(e.any());
  EXPECT_THROW(ApplyEffect(e, "steer_offset=1.5"), ConfigError);
  EXPECT_THROW(ApplyEffect(e, "steer_offset_deg=abc"), ConfigError);
  EXPECT_THROW(ApplyEffect(e, "steer_offset_deg"), ConfigError);
  EXPECT_THROW(ApplyEffect(e, "steer_offset_deg=1.5x"), ConfigError);
}

}  // namespace
}  // namespace ndsid::config
