#include "ndsid/config/config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "minimal_config.h"
#include "ndsid/dbc/dbc_parser.h"

namespace ndsid::config {
namespace {

using testing::ErrorOf;
using testing::kMinimal;

// Catches: unit or sign conversion done wrong (a right-positive a_y bus must become left-positive).
TEST(Config, ConvertsUnitsAndSignToSi) {
  const Config c = ParseConfig(kMinimal, "dir/car.yaml");
  EXPECT_NEAR(c.role(Role::kSteeringWheelAngle)->ToSi(180.0), M_PI, 1e-12);
  EXPECT_NEAR(c.role(Role::kSpeed)->ToSi(36.0), 10.0, 1e-12);
  EXPECT_DOUBLE_EQ(c.role(Role::kLateralAcceleration)->ToSi(1.5), -1.5);
  EXPECT_EQ(c.role(Role::kYawRate), nullptr);
  EXPECT_EQ(c.source.logs.at(0), "dir/a.log");  // relative to the config file
  EXPECT_EQ(c.dbc, "dir/b.dbc");
  EXPECT_TRUE(c.identification.params[0].fixed);
  EXPECT_DOUBLE_EQ(c.identification.params[0].initial, 1500.0);  // m from the data sheet
}

// Catches: a path in the config resolved against the working directory instead of the
// config file's folder (report_dir was, so reports landed wherever the command ran).
TEST(Config, ResolvesEveryPathRelativeToTheConfigFile) {
  const Config c = ParseConfig(std::string(kMinimal) + "state_dir: ../state\nreport_dir: out/report\n", "/cars/x/car.yaml");
  EXPECT_EQ(c.source.logs.at(0), "/cars/x/a.log");
  EXPECT_EQ(c.dbc, "/cars/x/b.dbc");
  EXPECT_EQ(c.state_dir, "/cars/state");
  EXPECT_EQ(c.report_dir, "/cars/x/out/report");
  const Config abs = ParseConfig(std::string(kMinimal) + "report_dir: /var/tmp/r\n", "/cars/x/car.yaml");
  EXPECT_EQ(abs.report_dir, "/var/tmp/r");
  // Absent, the documented default stays relative to the working directory.
  EXPECT_EQ(ParseConfig(kMinimal, "/cars/x/car.yaml").report_dir, "out/report");
}

// Catches: a typo in a key silently ignored (the user thinks a setting is active).
TEST(Config, RejectsUnknownKeyWithPathAndLine) {
  const std::string e = ErrorOf(std::string(kMinimal) + "gate: {min_sped_mps: 3}\n");
  EXPECT_NE(e.find("car.yaml:8"), std::string::npos) << e;
  EXPECT_NE(e.find("gate.min_sped_mps: unknown key"), std::string::npos) << e;
  // ... and names the closest accepted key and lists them all.
  EXPECT_NE(e.find("did you mean 'min_speed_mps'?"), std::string::npos) << e;
  EXPECT_NE(e.find("accepted: "), std::string::npos) << e;
  EXPECT_NE(e.find("standstill_speed_mps"), std::string::npos) << e;
}

TEST(Config, UnknownUnitNamesTheClosestAndTheAcceptedUnits) {
  std::string y = kMinimal;
  y.replace(y.find("unit: km/h"), 10, "unit: km/hr");
  const std::string e = ErrorOf(y);
  EXPECT_NE(e.find("did you mean 'km/h'? (accepted: km/h, kph, m/s, mph)"), std::string::npos) << e;
}

// Catches: the optional wheel_speed role read with another role's units, or required.
TEST(Config, WheelSpeedRoleTakesSpeedUnits) {
  EXPECT_EQ(ParseConfig(kMinimal, "car.yaml").role(Role::kWheelSpeed), nullptr);
  const Config c = ParseConfig(std::string(kMinimal) + "  wheel_speed: {expr: \"(W.FL + W.FR) / 2\", unit: mph}\n", "car.yaml");
  ASSERT_NE(c.role(Role::kWheelSpeed), nullptr);
  EXPECT_NEAR(c.role(Role::kWheelSpeed)->ToSi(10.0), 4.4704, 1e-12);
  EXPECT_EQ(c.role(Role::kWheelSpeed)->inputs.size(), 2u);
  const std::string e = ErrorOf(std::string(kMinimal) + "  wheel_speed: {message: W, signal: FL, unit: deg/s}\n");
  EXPECT_NE(e.find("(accepted: km/h, kph, m/s, mph)"), std::string::npos) << e;
}

TEST(Config, RejectsWrongTypeWithPathAndLine) {
  const std::string e = ErrorOf(std::string(kMinimal) + "gate:\n  min_speed_mps: fast\n");
  EXPECT_NE(e.find("car.yaml:9"), std::string::npos) << e;
  EXPECT_NE(e.find("gate.min_speed_mps"), std::string::npos) << e;
}

TEST(Config, RejectsMissingRequiredRole) {
  std::string y = kMinimal;
  y.erase(y.find("  lateral_acceleration"));
  const std::string e = ErrorOf(y);
  EXPECT_NE(e.find("signals.lateral_acceleration: missing required role"), std::string::npos) << e;
}

TEST(Config, RejectsUnknownUnitForRole) {
  std::string y = kMinimal;
  y.replace(y.find("unit: km/h"), 10, "unit: furlong/fortnight");
  const std::string e = ErrorOf(y);
  EXPECT_NE(e.find("signals.vehicle_speed.unit"), std::string::npos) << e;
}

TEST(Config, RejectsBrokenYamlWithLocation) {
  const std::string e = ErrorOf("vehicle: {name: car\nsource: [");
  EXPECT_NE(e.find("car.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("YAML syntax"), std::string::npos) << e;
}

// Catches: an identification.outputs value read wrongly, or a bad one accepted or reported
// without its place (the default: both outputs when the bus has a yaw rate, else a_y alone).
TEST(Config, IdentificationOutputsAcceptsAyOrAyAndYawRateWithLocatedErrors) {
  EXPECT_FALSE(ParseConfig(kMinimal, "car.yaml").identification.yaw_rate_output) << "no yaw rate role";
  std::string with_yaw(kMinimal);
  const std::string at = "signals:\n";
  ASSERT_NE(with_yaw.find(at), std::string::npos);
  with_yaw.insert(with_yaw.find(at) + at.size(), "  yaw_rate: {message: M, signal: R, unit: deg/s}\n");
  EXPECT_TRUE(ParseConfig(with_yaw, "car.yaml").identification.yaw_rate_output) << "a yaw rate role: both by default";
  EXPECT_FALSE(ParseConfig(with_yaw + "identification: {outputs: [a_y]}\n", "car.yaml").identification.yaw_rate_output);
  EXPECT_FALSE(ParseConfig(std::string(kMinimal) + "identification: {outputs: [a_y]}\n", "car.yaml").identification.yaw_rate_output);
  EXPECT_TRUE(ParseConfig(std::string(kMinimal) + "identification:\n  outputs: [a_y, yaw_rate]\n", "car.yaml")
                  .identification.yaw_rate_output);
  for (const char* bad : {"[yaw_rate]", "[a_y, roll_rate]", "[a_y, yaw_rate, a_y]", "[]"}) {
    const std::string e = ErrorOf(std::string(kMinimal) + "identification:\n  outputs: " + bad + "\n");
    EXPECT_NE(e.find("car.yaml:9"), std::string::npos) << bad << ": " << e;
    EXPECT_NE(e.find("identification.outputs"), std::string::npos) << bad << ": " << e;
  }
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "identification:\n  outputs: yaw\n").find("identification.outputs"),
            std::string::npos);
}

TEST(Config, RejectsInitialOutsideBox) {
  const std::string e =
      ErrorOf(std::string(kMinimal) + "identification:\n  parameters:\n    is: {min: 14, max: 15, initial: 20}\n");
  EXPECT_NE(e.find("identification.parameters.is"), std::string::npos) << e;
}

// Catches: a role mapped to a signal the DBC does not have, found only at the first frame.
// Catches: model.priors read wrongly or a meaningless prior accepted silently.
TEST(Config, ReadsPriorsAndRejectsNonPositiveSdWithLine) {
  const Config c = ParseConfig(std::string(kMinimal) +
                                   "model:\n  priors:\n    roll_gradient_rad_per_mps2: {value: 0.009, sd: 0.001}\n",
                               "car.yaml");
  ASSERT_EQ(c.identification.priors.size(), 1u);
  EXPECT_EQ(c.identification.priors[0].name, "roll_gradient_rad_per_mps2");
  EXPECT_DOUBLE_EQ(c.identification.priors[0].value, 0.009);
  EXPECT_DOUBLE_EQ(c.identification.priors[0].sd, 0.001);
  EXPECT_EQ(c.identification.priors[0].location, "car.yaml:10");
  const std::string e = ErrorOf(std::string(kMinimal) + "model:\n  priors:\n    is: {value: 15, sd: 0}\n");
  EXPECT_NE(e.find("car.yaml:10"), std::string::npos) << e;
  EXPECT_NE(e.find("sd > 0"), std::string::npos) << e;
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "model:\n  priors:\n    is: {value: 15, sd: 1, mean: 3}\n").find("unknown key"),
            std::string::npos);
}

TEST(Config, ValidateAgainstDbcNamesMissingSignalAndLine) {
  const Config c = ParseConfig(kMinimal, "car.yaml");
  const dbc::Database db = dbc::ParseDbcText(
      "VERSION \"\"\nBO_ 100 M: 8 X\n SG_ S : 0|16@1- (0.1,0) [0|0] \"deg\" X\n SG_ V : 16|16@1+ (0.01,0) [0|0] \"km/h\" X\n",
      "t.dbc");
  try {
    ValidateAgainstDbc(c, db);
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("car.yaml:7"), std::string::npos) << m;
    EXPECT_NE(m.find("signal 'A' not in message 'M'"), std::string::npos) << m;
  }
}

// Catches: the shipped example drifting out of sync with the loader or the example DBC.
TEST(Config, ShippedExampleConfigsLoadAndMatchTheirDbc) {
  const Config c = LoadConfig(std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml");
  ValidateAgainstDbc(c, dbc::ParseDbcFile(c.dbc));
  EXPECT_NE(c.role(Role::kYawRate), nullptr);
  EXPECT_EQ(c.validity.size(), 2u);
}

// Catches: a role latency not read, out of range accepted, or set on the time reference.
TEST(Config, ReadsRoleLatencyAndRejectsItOnTheReference) {
  std::string yaml = kMinimal;
  yaml.replace(yaml.find("unit: deg}"), 10, "unit: deg, latency_s: 0.06}");
  EXPECT_DOUBLE_EQ(ParseConfig(yaml, "car.yaml").role(Role::kSteeringWheelAngle)->latency_s, 0.06);
  EXPECT_DOUBLE_EQ(ParseConfig(kMinimal, "car.yaml").role(Role::kSpeed)->latency_s, 0.0);
  std::string far = kMinimal;
  far.replace(far.find("unit: deg}"), 10, "unit: deg, latency_s: 2}");
  EXPECT_NE(ErrorOf(far).find("car.yaml:5: signals.steering_wheel_angle.latency_s"), std::string::npos) << ErrorOf(far);
  std::string ref = kMinimal;
  ref.replace(ref.find("sign: -1}"), 9, "sign: -1, latency_s: 0.01}");
  EXPECT_NE(ErrorOf(ref).find("time reference"), std::string::npos) << ErrorOf(ref);
}

}  // namespace
}  // namespace ndsid::config
