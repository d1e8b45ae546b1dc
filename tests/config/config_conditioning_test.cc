// The keys of the validity work: a role's low-pass, the vehicle's optional data-sheet values,
// the limits of the fit's checks, and the parameter box a config without one gets.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "minimal_config.h"
#include "ndsid/config/config.h"
#include "ndsid/config/parameter_box.h"

namespace ndsid::config {
namespace {

using testing::ErrorOf;
using testing::kMinimal;

std::string With(std::string yaml, const std::string& what, const std::string& by) {
  yaml.replace(yaml.find(what), what.size(), by);
  return yaml;
}

// Catches: lowpass_hz not read, or a cutoff the sync grid cannot run accepted.
TEST(ConfigConditioning, ReadsALowPassAndRefusesOneAboveAQuarterOfTheSyncRate) {
  const std::string y = With(kMinimal, "sign: -1}", "sign: -1, lowpass_hz: 4}");
  const Config c = ParseConfig(y, "car.yaml");
  EXPECT_DOUBLE_EQ(c.role(Role::kLateralAcceleration)->lowpass_hz, 4.0);
  EXPECT_DOUBLE_EQ(c.role(Role::kSpeed)->lowpass_hz, 0.0);  // none unless asked
  const std::string fast = With(kMinimal, "sign: -1}", "sign: -1, lowpass_hz: 30}") + "sync: {rate_hz: 100}\n";
  const std::string e = ErrorOf(fast);
  EXPECT_NE(e.find("signals.lateral_acceleration.lowpass_hz"), std::string::npos) << e;
  EXPECT_NE(e.find("quarter of sync.rate_hz (100 Hz)"), std::string::npos) << e;
  EXPECT_EQ(ErrorOf(With(kMinimal, "sign: -1}", "sign: -1, lowpass_hz: 20}") + "sync: {rate_hz: 100}\n"), "");
  EXPECT_NE(ErrorOf(With(kMinimal, "sign: -1}", "sign: -1, lowpass_hz: -1}")).find("out of range"), std::string::npos);
}

// Catches: the rear wheels' difference accepted without the track that turns it into a yaw rate.
TEST(ConfigConditioning, TheRearWheelDifferenceNeedsTheRearTrack) {
  const std::string role = "  rear_wheel_speed_difference: {expr: \"M.RR - M.RL\", unit: km/h}\n";
  const std::string without = With(kMinimal, "sign: -1}\n", "sign: -1}\n" + role);
  const std::string e = ErrorOf(without);
  EXPECT_NE(e.find("signals.rear_wheel_speed_difference"), std::string::npos) << e;
  EXPECT_NE(e.find("needs vehicle.track_rear_m"), std::string::npos) << e;
  const std::string with = With(without, "mass_kg: 1500}", "mass_kg: 1500, track_rear_m: 1.6}");
  const Config c = ParseConfig(with, "car.yaml");
  ASSERT_NE(c.role(Role::kRearWheelSpeedDifference), nullptr);
  EXPECT_DOUBLE_EQ(c.role(Role::kRearWheelSpeedDifference)->scale_to_si, 1 / 3.6);
  EXPECT_DOUBLE_EQ(c.vehicle.track_rear_m, 1.6);
}

// Catches: one axle load without the other, or loads that contradict the mass, taken silently.
TEST(ConfigConditioning, AxleLoadsComeInPairsThatAddUpToTheMass) {
  const std::string pair = With(kMinimal, "mass_kg: 1500}", "mass_kg: 1500, front_axle_load_kg: 870, rear_axle_load_kg: 630}");
  const Config c = ParseConfig(pair, "car.yaml");
  EXPECT_DOUBLE_EQ(c.vehicle.front_axle_load_kg, 870);
  EXPECT_DOUBLE_EQ(c.vehicle.rear_axle_load_kg, 630);
  const std::string one = With(kMinimal, "mass_kg: 1500}", "mass_kg: 1500, front_axle_load_kg: 870}");
  EXPECT_NE(ErrorOf(one).find("give both axle loads or neither"), std::string::npos) << ErrorOf(one);
  const std::string off = With(kMinimal, "mass_kg: 1500}", "mass_kg: 1500, front_axle_load_kg: 1300, rear_axle_load_kg: 900}");
  EXPECT_NE(ErrorOf(off).find("more than 15 % from mass_kg"), std::string::npos) << ErrorOf(off);
}

// Catches: a config without identification.parameters pinned to another car's box (the
// example car's box made every parameter of a heavier car end on a bound).
TEST(ConfigConditioning, WithoutABoxEachParameterGetsThisCarsPhysicalBox) {
  const std::string van = With(kMinimal, "wheelbase_m: 2.6, mass_kg: 1500", "wheelbase_m: 3.66, mass_kg: 3500");
  const Config c = ParseConfig(van, "car.yaml");
  VehicleConfig v;
  v.wheelbase_m = 3.66;
  v.mass_kg = 3500;
  const auto box = PhysicalParameterBox(v);
  for (int i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(c.identification.params[i].lower, box[i].lower) << i;
    EXPECT_DOUBLE_EQ(c.identification.params[i].upper, box[i].upper) << i;
    EXPECT_DOUBLE_EQ(c.identification.params[i].initial, box[i].initial) << i;
  }
  EXPECT_TRUE(c.identification.params[0].fixed);
  EXPECT_DOUBLE_EQ(c.identification.params[0].initial, 3500);
  // lv's box is this car's: from a quarter to three quarters of its wheelbase.
  EXPECT_NEAR(c.identification.params[4].lower, 0.25 * 3.66, 1e-9);
  EXPECT_NEAR(c.identification.params[4].upper, 0.75 * 3.66, 1e-9);
  // A parameter the config states keeps its own box, its initial value the middle of it; the
  // others stay physical.
  const Config own = ParseConfig(van + "identification:\n  parameters:\n    lv: {min: 1.5, max: 1.9}\n", "car.yaml");
  EXPECT_DOUBLE_EQ(own.identification.params[4].lower, 1.5);
  EXPECT_DOUBLE_EQ(own.identification.params[4].initial, 1.7);
  EXPECT_DOUBLE_EQ(own.identification.params[2].upper, box[2].upper);
}

// Catches: a limit of the fit's checks not read, or an absurd one accepted.
TEST(ConfigConditioning, ReadsTheLimitsOfTheFitsChecks) {
  const Config c = ParseConfig(std::string(kMinimal) +
                                   "plausibility: {rmse_floor_ratio_max: 8, rmse_spread_ratio_max: 0.4, "
                                   "bound_shift_sigma_max: 2, steady_state_z_max: 4, steady_state_rel_bias: 0.2, "
                                   "halves_z_max: 5}\n",
                               "car.yaml");
  EXPECT_DOUBLE_EQ(c.plausibility.rmse_floor_ratio_max, 8);
  EXPECT_DOUBLE_EQ(c.plausibility.rmse_spread_ratio_max, 0.4);
  EXPECT_DOUBLE_EQ(c.plausibility.bound_shift_sigma_max, 2);
  EXPECT_DOUBLE_EQ(c.plausibility.steady_state_z_max, 4);
  EXPECT_DOUBLE_EQ(c.plausibility.steady_state_rel_bias, 0.2);
  EXPECT_DOUBLE_EQ(c.plausibility.halves_z_max, 5);
  const std::string e = ErrorOf(std::string(kMinimal) + "plausibility: {rmse_floor_ratio_max: 0.5}\n");
  EXPECT_NE(e.find("plausibility.rmse_floor_ratio_max: value 0.5 out of range"), std::string::npos) << e;
}

// Catches: identification.prior_from not read, the per-kg parameters not scaled by this
// vehicle's mass, a model.priors entry overridden by the fleet's, or a broken file accepted.
TEST(ConfigConditioning, AFleetPriorJoinsThePriorsScaledToThisVehiclesMass) {
  const auto dir = std::filesystem::temp_directory_path() / ("ndsid_prior_from_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    std::ofstream f(dir / "fleet_prior.yaml");
    f << "group: g\nparameters:\n  Jz_per_m: {mean: 1.4, sd: 0.1}\n  cv_per_m: {mean: 40, sd: 2}\n"
         "  lv: {mean: 1.1, sd: 0.05}\n";
  }
  const std::string y = std::string(kMinimal) + "identification: {prior_from: fleet_prior.yaml}\n" +
                        "model:\n  priors:\n    lv: {value: 1.2, sd: 0.01}\n";
  const Config c = ParseConfig(y, (dir / "car.yaml").string());
  auto find = [&](const std::string& n) -> const ParameterPrior* {
    for (const auto& p : c.identification.priors)
      if (p.name == n) return &p;
    return nullptr;
  };
  ASSERT_NE(find("Jz"), nullptr);
  EXPECT_DOUBLE_EQ(find("Jz")->value, 1.4 * 1500);  // per kg of this vehicle's 1500 kg
  EXPECT_DOUBLE_EQ(find("Jz")->sd, 0.1 * 1500);
  EXPECT_DOUBLE_EQ(find("cv")->value, 40 * 1500);
  EXPECT_EQ(find("ch"), nullptr);                   // not in the fleet's file
  EXPECT_DOUBLE_EQ(find("lv")->value, 1.2);         // the configuration's own prior wins
  EXPECT_EQ(c.identification.priors.size(), 3u);
  {
    std::ofstream f(dir / "broken.yaml");
    f << "parameters:\n  lv: {mean: -1, sd: 0.1}\n";
  }
  const std::string bad = std::string(kMinimal) + "identification: {prior_from: broken.yaml}\n";
  try {
    ParseConfig(bad, (dir / "car.yaml").string());
    ADD_FAILURE() << "a negative mean was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("identification.prior_from"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("parameters.lv"), std::string::npos) << e.what();
  }
  const std::string missing = std::string(kMinimal) + "identification: {prior_from: nowhere.yaml}\n";
  EXPECT_THROW(ParseConfig(missing, (dir / "car.yaml").string()), ConfigError);
  std::filesystem::remove_all(dir);
}

// Catches: a fleet table named with its group not resolved to the group's prior beside it, a
// prior from another version of the table (its size and CRC-32 recorded) accepted, a group's
// name not mapped to its folder as `ndsid fleet` writes it, or a missing group or mismatch
// accepted without a located error.
TEST(ConfigConditioning, AFleetTableWithItsGroupReadsThatGroupsPriorWhileTheTableIsUnchanged) {
  const auto dir = std::filesystem::temp_directory_path() / ("ndsid_prior_table_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir / "out" / "groups" / "cmax_2019");
  auto write = [&](const std::filesystem::path& p, const std::string& text) { std::ofstream(p) << text; };
  write(dir / "out" / "fleet.parquet", "123456789");  // CRC-32 cbf43926, the standard check value
  write(dir / "out" / "groups" / "cmax_2019" / "fleet_prior.yaml",
        "group: cmax 2019\nsource: {table: fleet.parquet, bytes: 9, crc32: cbf43926}\n"
        "parameters:\n  ch_per_m: {mean: 60, sd: 3}\n  is: {mean: 15.5, sd: 0.2}\n"
        "eg_deg_per_g: {mean: 4.19, sd: 0.011}\n");
  const std::string car = (dir / "car.yaml").string();
  const std::string y = std::string(kMinimal) + "identification: {prior_from: out/fleet.parquet, prior_group: cmax 2019}\n";
  const Config c = ParseConfig(y, car);
  ASSERT_EQ(c.identification.priors.size(), 3u);
  EXPECT_EQ(c.identification.priors[0].name, "ch");
  EXPECT_DOUBLE_EQ(c.identification.priors[0].value, 60 * 1500);
  EXPECT_DOUBLE_EQ(c.identification.priors[1].sd, 0.2);
  EXPECT_EQ(c.identification.priors[2].name, kEgPriorName);  // the group's EG, in deg/g as written
  EXPECT_DOUBLE_EQ(c.identification.priors[2].value, 4.19);
  EXPECT_DOUBLE_EQ(c.identification.priors[2].sd, 0.011);

  auto error = [&](const std::string& yaml) {
    try {
      ParseConfig(yaml, car);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  std::string e = error(std::string(kMinimal) + "identification: {prior_from: out/fleet.parquet}\n");
  EXPECT_NE(e.find("identification.prior_group"), std::string::npos) << e;
  e = error(std::string(kMinimal) + "identification: {prior_from: out/fleet.parquet, prior_group: van}\n");
  EXPECT_NE(e.find("no prior for this group"), std::string::npos) << e;
  e = error(std::string(kMinimal) + "identification: {prior_group: van}\n");
  EXPECT_NE(e.find("needs prior_from"), std::string::npos) << e;
  e = error(std::string(kMinimal) + "identification: {prior_from: out/groups/cmax_2019/fleet_prior.yaml, prior_group: van}\n");
  EXPECT_NE(e.find("is the prior of group 'cmax 2019', not of 'van'"), std::string::npos) << e;
  write(dir / "out" / "groups" / "cmax_2019" / "bad.yaml", "parameters: {is: {mean: 15.5, sd: 0.2}}\neg_deg_per_g: {mean: 4.19, sd: 0}\n");
  e = error(std::string(kMinimal) + "identification: {prior_from: out/groups/cmax_2019/bad.yaml}\n");
  EXPECT_NE(e.find("eg_deg_per_g: a prior needs a finite mean and sd > 0"), std::string::npos) << e;

  write(dir / "out" / "fleet.parquet", "123456780");  // same size, other content
  e = error(y);
  EXPECT_NE(e.find("another version of"), std::string::npos) << e;
  EXPECT_NE(e.find("python -m ndsid fleet prior --fleet"), std::string::npos) << e;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ndsid::config
