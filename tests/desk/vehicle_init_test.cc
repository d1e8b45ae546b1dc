// `ndsid init`'s analysis (src/desk/vehicle_init.h) on real and simulated buses. The simulated
// bus is encoded with dbc/ndsid_example.dbc and decoded with variants of it whose factors put a
// signal in another unit or sign (what a new car's bus may do); init must recover each from the
// data alone, even where the variant's unit string is wrong.
#include "vehicle_init.h"

#include <gtest/gtest.h>
#include <spdlog/fmt/fmt.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "ndsid/can/frame_log.h"
#include "ndsid/config/config.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/sim/candump_writer.h"
#include "ndsid/sim/simulator.h"
#include "vehicle_init_detail.h"

namespace ndsid::desk {
namespace {

namespace fs = std::filesystem;
using config::Role;

// The simulated car's data sheet (the written config loads only with a wheelbase and a mass).
const VehicleSheet kSimSheet{.wheelbase_m = 2.648, .mass_kg = 1900};

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The SG_ line of `signal`: factor and unit replaced (the encoder's DBC keeps the originals).
std::string WithSignal(std::string dbc, const std::string& signal, double factor_scale, const std::string* unit = nullptr) {
  const std::regex line("( SG_ " + signal + " [^(]*\\()([-0-9.eE]+)(,[^)]*\\) \\[[^\\]]*\\] \")([^\"]*)(\")");
  std::smatch m;
  EXPECT_TRUE(std::regex_search(dbc, m, line)) << signal;
  std::ostringstream factor;
  factor.precision(12);
  factor << std::stod(m[2].str()) * factor_scale;
  const std::string replaced = m[1].str() + factor.str() + m[3].str() + (unit ? *unit : m[4].str()) + m[5].str();
  return dbc.replace(static_cast<size_t>(m.position(0)), static_cast<size_t>(m.length(0)), replaced);
}

std::string WithComment(std::string dbc, const std::string& signal, const std::string& comment) {
  const std::regex cm("(CM_ SG_ [0-9]+ " + signal + " \")[^\"]*(\";)");
  return std::regex_replace(dbc, cm, "$1" + comment + "$2");
}

InitResult Propose(const std::string& dbc_text, const std::string& log_path) {
  const dbc::Database db = dbc::ParseDbcText(dbc_text, "variant.dbc");
  auto log = can::OpenFrameLog(log_path);
  return ProposeVehicleConfig(db, *log);
}

class SimulatedBus : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(NDSID_BINARY_DIR) / "tests" / "desk" / "vehicle_init_sim";
    fs::create_directories(dir_);
    // One log per test process: ctest runs each test as its own process, in parallel (-j2), and
    // a shared file would be rewritten under another process's reader.
    log_ = (dir_ / ("drive." + std::to_string(::getpid()) + ".log")).string();
    example_dbc_ = ReadText(std::string(NDSID_SOURCE_DIR) + "/dbc/ndsid_example.dbc");
    config::SimulationConfig cfg;  // config/sim_cmax.yaml's defaults
    cfg.seed = 5;
    cfg.duration.hours = 0.25;
    const dbc::Database db = dbc::ParseDbcText(example_dbc_, "ndsid_example.dbc");
    sim::CandumpLogWriter writer(db, cfg, log_);
    sim::SimulateDrives(cfg, [&](sim::DriveResult&& d) { writer.WriteDrive(d); });
    writer.Close();
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove(log_, ec);
  }
  static fs::path dir_;
  static std::string log_;
  static std::string example_dbc_;
};
fs::path SimulatedBus::dir_;
std::string SimulatedBus::log_;
std::string SimulatedBus::example_dbc_;

void ExpectRole(const InitResult& r, Role role, const std::string& message, const std::string& signal,
                const std::string& unit, int sign) {
  const RoleProposal* p = r.Find(role);
  ASSERT_NE(p, nullptr);
  ASSERT_TRUE(p->found) << config::RoleKey(role) << ": " << p->reason;
  EXPECT_EQ(p->message, message) << config::RoleKey(role);
  EXPECT_EQ(p->signal, signal) << config::RoleKey(role);
  EXPECT_EQ(p->unit, unit) << config::RoleKey(role);
  EXPECT_EQ(p->sign, sign) << config::RoleKey(role);
}

// The example bus as its DBC says: everything in the DBC's units, ISO signs, and the yaw rate's
// comment ("positive counter-clockwise") fixes the absolute sign.
TEST_F(SimulatedBus, FindsEveryRoleOfTheExampleBus) {
  const InitResult r = Propose(example_dbc_, log_);
  EXPECT_TRUE(r.MandatoryFound());
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", 1);
  ExpectRole(r, Role::kSpeed, "VEHICLE_SPEED", "VehicleSpeed", "km/h", 1);
  ExpectRole(r, Role::kLateralAcceleration, "ESP_DYNAMICS", "LateralAcceleration", "m/s^2", 1);
  ExpectRole(r, Role::kYawRate, "ESP_DYNAMICS", "YawRate", "deg/s", 1);
  ExpectRole(r, Role::kLongitudinalAcceleration, "ESP_DYNAMICS", "LongitudinalAcceleration", "m/s^2", 1);
  for (const auto& p : r.roles) EXPECT_GE(p.confidence, 0.85) << config::RoleKey(p.role);
  // Timeouts from the measured periods: 10 ms messages -> 0.1 s, the 20 ms speed -> 0.2 s.
  EXPECT_DOUBLE_EQ(r.Find(Role::kSteeringWheelAngle)->timeout_s, 0.1);
  EXPECT_NEAR(r.Find(Role::kSpeed)->period_s, 0.02, 0.001);
  EXPECT_DOUBLE_EQ(r.Find(Role::kSpeed)->timeout_s, 0.2);
}

// Catches: a_y's sign taken from the DBC instead of a_y = v r.
TEST_F(SimulatedBus, RecoversFlippedLateralAccelerationSign) {
  const InitResult r = Propose(WithSignal(example_dbc_, "LateralAcceleration", -1.0), log_);
  ExpectRole(r, Role::kLateralAcceleration, "ESP_DYNAMICS", "LateralAcceleration", "m/s^2", -1);
  ExpectRole(r, Role::kYawRate, "ESP_DYNAMICS", "YawRate", "deg/s", 1);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", 1);
}

// Steering sent in rad although the DBC says deg: the steer ratio would be 850 in deg.
TEST_F(SimulatedBus, RecoversSteeringInRadiansDespiteTheUnitString) {
  const InitResult r = Propose(WithSignal(example_dbc_, "SteeringWheelAngle", M_PI / 180.0), log_);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "rad", 1);
}

TEST_F(SimulatedBus, RecoversSpeedInMetresPerSecondWithoutAUnitString) {
  const std::string none;
  const InitResult r = Propose(WithSignal(example_dbc_, "VehicleSpeed", 1.0 / 3.6, &none), log_);
  ExpectRole(r, Role::kSpeed, "VEHICLE_SPEED", "VehicleSpeed", "m/s", 1);
  ExpectRole(r, Role::kLateralAcceleration, "ESP_DYNAMICS", "LateralAcceleration", "m/s^2", 1);
}

// A speed counted negative forward (signed signal, negative factor): sign -1, and the steering
// fit (which needs v > 4 m/s) still works.
TEST_F(SimulatedBus, RecoversNegativeSpeedSign) {
  std::string dbc = WithSignal(example_dbc_, "VehicleSpeed", -1.0);
  dbc = std::regex_replace(dbc, std::regex("VehicleSpeed : 8\\|16@1\\+"), "VehicleSpeed : 8|16@1-");
  const InitResult r = Propose(dbc, log_);
  ExpectRole(r, Role::kSpeed, "VEHICLE_SPEED", "VehicleSpeed", "km/h", -1);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", 1);
  EXPECT_GE(r.Find(Role::kSpeed)->confidence, 0.85);  // the wheel speeds agree in magnitude
}

// mph labelled km/h: a_y = v r and the wheel speeds (km/h) both say mph.
TEST_F(SimulatedBus, RecoversSpeedInMphDespiteTheUnitString) {
  const InitResult r = Propose(WithSignal(example_dbc_, "VehicleSpeed", 1.0 / 1.609344), log_);
  ExpectRole(r, Role::kSpeed, "VEHICLE_SPEED", "VehicleSpeed", "mph", 1);
  // The wheel speeds stay km/h: the wheel_speed role gets its own unit, not the speed's.
  const RoleProposal* w = r.Find(Role::kWheelSpeed);
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->unit, "km/h");
  EXPECT_EQ(w->expression.rfind("(WHEEL_SPEEDS.WheelSpeed", 0), 0u) << w->expression;
  EXPECT_NE(w->expression.find(") / 4"), std::string::npos) << w->expression;
}

TEST_F(SimulatedBus, RecoversYawRateInRadiansPerSecond) {
  const std::string none;
  const InitResult r = Propose(WithSignal(example_dbc_, "YawRate", M_PI / 180.0, &none), log_);
  ExpectRole(r, Role::kYawRate, "ESP_DYNAMICS", "YawRate", "rad/s", 1);
  ExpectRole(r, Role::kLateralAcceleration, "ESP_DYNAMICS", "LateralAcceleration", "m/s^2", 1);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", 1);
}

TEST_F(SimulatedBus, RecoversLateralAccelerationInG) {
  const std::string none;
  const InitResult r = Propose(WithSignal(example_dbc_, "LateralAcceleration", 1.0 / 9.80665, &none), log_);
  ExpectRole(r, Role::kLateralAcceleration, "ESP_DYNAMICS", "LateralAcceleration", "g", 1);
}

// A bus whose yaw rate and steering are positive to the right, and a DBC comment that says so:
// the absolute sign comes from the comment, a_y's and the steering's relative to it from physics.
TEST_F(SimulatedBus, TakesTheAbsoluteSignFromAClockwiseComment) {
  std::string dbc = WithSignal(example_dbc_, "YawRate", -1.0);
  dbc = WithSignal(dbc, "SteeringWheelAngle", -1.0);
  dbc = WithComment(dbc, "YawRate", "Yaw rate, positive clockwise seen from above.");
  dbc = WithComment(dbc, "SteeringWheelAngle", "Steering-wheel angle.");
  const InitResult r = Propose(dbc, log_);
  ExpectRole(r, Role::kYawRate, "ESP_DYNAMICS", "YawRate", "deg/s", -1);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", -1);
  ExpectRole(r, Role::kLateralAcceleration, "ESP_DYNAMICS", "LateralAcceleration", "m/s^2", 1);
}

// Without a comment the absolute sign is an assumption, and the result says so; the three
// signs are still right relative to each other (all off by the same factor).
TEST_F(SimulatedBus, StatesTheAssumptionWhenNothingFixesTheAbsoluteSign) {
  std::string dbc = WithSignal(example_dbc_, "YawRate", -1.0);
  dbc = WithComment(dbc, "YawRate", "Yaw rate.");
  dbc = WithComment(dbc, "LateralAcceleration", "Lateral acceleration.");
  const InitResult r = Propose(dbc, log_);
  ASSERT_TRUE(r.MandatoryFound());
  const int global = r.Find(Role::kYawRate)->sign * -1;  // the bus's truth: yaw -1, a_y +1, steering +1
  EXPECT_EQ(r.Find(Role::kLateralAcceleration)->sign * 1, global);
  EXPECT_EQ(r.Find(Role::kSteeringWheelAngle)->sign * 1, global);
  bool stated = false;
  for (const auto& n : r.notes) stated |= n.find("ASSUMED") != std::string::npos;
  EXPECT_TRUE(stated);
  EXPECT_LE(r.Find(Role::kYawRate)->confidence, 0.7);
}

// A role whose signal has a name nothing recognises is written commented out with the reason;
// the written config loads and has the found roles as proposed.
TEST_F(SimulatedBus, WrittenConfigLoadsAndListsRolesNotFound) {
  std::string dbc = example_dbc_;
  dbc = std::regex_replace(dbc, std::regex("LongitudinalAcceleration"), "Signal7");
  const fs::path dbc_path = dir_ / "renamed.dbc";
  std::ofstream(dbc_path) << dbc;
  const InitResult r = Propose(dbc, log_);
  ASSERT_TRUE(r.MandatoryFound());
  EXPECT_FALSE(r.Find(Role::kLongitudinalAcceleration)->found);
  const std::string yaml = VehicleConfigYaml(r, {"sim", log_, dbc_path.string(), "test", "sim", kSimSheet});
  EXPECT_NE(yaml.find("# longitudinal_acceleration: not found: no varying signal named like"), std::string::npos) << yaml;
  const fs::path out = dir_ / "vehicle.yaml";
  std::ofstream(out) << yaml;
  const config::Config c = config::LoadConfig(out.string());
  for (Role role : {Role::kSteeringWheelAngle, Role::kSpeed, Role::kLateralAcceleration, Role::kYawRate}) {
    const RoleProposal* p = r.Find(role);
    ASSERT_NE(c.role(role), nullptr) << config::RoleKey(role);
    EXPECT_EQ(c.role(role)->ref.message, p->message);
    EXPECT_EQ(c.role(role)->ref.signal, p->signal);
    EXPECT_DOUBLE_EQ(c.role(role)->scale_to_si, p->sign * config::UnitToSi(role, p->unit));
    EXPECT_DOUBLE_EQ(c.role(role)->timeout_s, p->timeout_s);
  }
  EXPECT_EQ(c.role(Role::kLongitudinalAcceleration), nullptr);
  // A yaw rate on the bus: both outputs, the bank tracked through it, the gyro's offset.
  EXPECT_TRUE(c.identification.yaw_rate_output);
  EXPECT_EQ(c.model_effects, (std::vector<std::string>{"road_bank", "gyro_offset"}));
}

// Catches: the rear wheels' difference not proposed where the names give the rear corners, or
// written active without the track it needs (the config would not load).
TEST_F(SimulatedBus, ProposesTheRearWheelDifferenceWrittenActiveOnlyWithTheTrack) {
  const InitResult r = Propose(example_dbc_, log_);
  const RoleProposal* p = r.Find(Role::kRearWheelSpeedDifference);
  ASSERT_NE(p, nullptr);
  ASSERT_TRUE(p->found);
  EXPECT_EQ(p->expression, "WHEEL_SPEEDS.WheelSpeedRR - WHEEL_SPEEDS.WheelSpeedRL");
  EXPECT_EQ(p->unit, "km/h");
  const fs::path dbc_path = dir_ / "example.dbc";
  std::ofstream(dbc_path) << example_dbc_;
  for (const double track : {0.0, 1.55}) {
    VehicleSheet sheet = kSimSheet;
    sheet.track_rear_m = track;
    const std::string yaml = VehicleConfigYaml(r, {"sim", log_, dbc_path.string(), "test", "sim", sheet});
    const bool commented = yaml.find("  # rear_wheel_speed_difference: {expr:") != std::string::npos;
    EXPECT_EQ(commented, track == 0) << yaml;
    const fs::path out = dir_ / ("rear_" + std::to_string(::getpid()) + ".yaml");
    std::ofstream(out) << yaml;
    const config::Config c = config::LoadConfig(out.string());
    const config::RoleSignal* role = c.role(Role::kRearWheelSpeedDifference);
    if (track == 0) {
      EXPECT_EQ(role, nullptr);
    } else {
      ASSERT_NE(role, nullptr);
      EXPECT_EQ(role->expr, p->expression);
      EXPECT_DOUBLE_EQ(c.vehicle.track_rear_m, 1.55);
    }
  }
}

// Without a yaw rate the written config fits a_y alone with the base model (nothing reads a
// yaw rate it does not have).
TEST_F(SimulatedBus, WithoutAYawRateTheConfigFitsAyAlone) {
  const std::string dbc = std::regex_replace(example_dbc_, std::regex("YawRate"), "Signal9");
  const fs::path dbc_path = dir_ / "no_yaw.dbc";
  std::ofstream(dbc_path) << dbc;
  const InitResult r = Propose(dbc, log_);
  ASSERT_TRUE(r.MandatoryFound());
  ASSERT_FALSE(r.Find(Role::kYawRate)->found);
  const fs::path out = dir_ / "no_yaw.yaml";
  std::ofstream(out) << VehicleConfigYaml(r, {"sim", log_, dbc_path.string(), "test", "sim", kSimSheet});
  const config::Config c = config::LoadConfig(out.string());
  EXPECT_FALSE(c.identification.yaw_rate_output);
  EXPECT_TRUE(c.model_effects.empty());
}

// The RAV4's split steering angle, made from the example bus: the same 16 bits decoded as a
// coarse signal (the upper 12 bits, 1.6 deg steps) plus a fine one (the lower 4 bits, 0.1 deg):
// coarse + fine is the angle exactly. Init must find the pair and write it as a role expression.
TEST_F(SimulatedBus, FindsCoarsePlusFineSteeringPair) {
  std::string dbc = example_dbc_;
  const std::regex original(" SG_ SteeringWheelAngle : 7\\|16@0- \\(0\\.1,0\\) [^\\n]*\\n");
  ASSERT_TRUE(std::regex_search(dbc, original));
  dbc = std::regex_replace(dbc, original,
                           " SG_ SteeringWheelAngle : 7|12@0- (1.6,0) [-3276.8|3276.7] \"deg\" LOGGER\n"
                           " SG_ SteeringAngleFine : 11|4@0+ (0.1,0) [0|1.5] \"deg\" LOGGER\n");
  const InitResult r = Propose(dbc, log_);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", 1);
  const RoleProposal* p = r.Find(Role::kSteeringWheelAngle);
  EXPECT_TRUE(p->multi_signal);
  EXPECT_EQ(p->expression, "STEERING_SENSOR.SteeringWheelAngle + STEERING_SENSOR.SteeringAngleFine");
  const std::string yaml = VehicleConfigYaml(r, {"sim", log_, "split.dbc", "test", "sim", {}});
  EXPECT_NE(yaml.find("  steering_wheel_angle: {expr: \"STEERING_SENSOR.SteeringWheelAngle + STEERING_SENSOR.SteeringAngleFine\", "
                      "unit: deg, sign: 1, timeout_s: 0.1}"),
            std::string::npos)
      << yaml;
}

// Two signals with the same bits of the same frames (identical data, identical fits), the first
// declared without range or comment: the DBC's comment and declared range decide. (Without them
// the first listed would win the tie.)
TEST_F(SimulatedBus, CommentAndRangeDecideBetweenEqualCandidates) {
  std::string dbc = example_dbc_;
  const std::string anchor = " SG_ SteeringWheelAngle : ";
  dbc.insert(dbc.find(anchor), " SG_ SteeringAngleCopy : 7|16@0- (0.1,0) [0|0] \"deg\" LOGGER\n");
  const InitResult r = Propose(dbc, log_);
  ExpectRole(r, Role::kSteeringWheelAngle, "STEERING_SENSOR", "SteeringWheelAngle", "deg", 1);
}

// Wheel speeds are candidates by a corner in their name (English, German codes and words) and a
// speed-like unit or name; the data then decide. Catches: German corners (VL/HR, "links vorne")
// or rotational speeds (1/min) never proposed, and one wheel's speed taken for the vehicle's.
TEST(VehicleInitNames, WheelCornersAndRotationalSpeeds) {
  const std::string dbc =
      "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: ECU\n\n"
      "BO_ 1 WHEELS: 8 ECU\n"
      " SG_ WheelSpeedFL : 0|8@1+ (1,0) [0|255] \"km/h\" ECU\n"
      " SG_ ESP_Raddrehzahl_HR : 8|8@1+ (1,0) [0|255] \"1/min\" ECU\n"
      " SG_ Radgeschw_links_vorne : 16|8@1+ (1,0) [0|255] \"m/s\" ECU\n"
      " SG_ WheelSpeedRearRight : 24|8@1+ (1,0) [0|255] \"\" ECU\n"
      " SG_ Reifendruck_VL : 32|8@1+ (1,0) [0|255] \"bar\" ECU\n"
      " SG_ Radimpulse_HL : 40|8@1+ (1,0) [0|255] \"\" ECU\n";
  const dbc::Database db = dbc::ParseDbcText(dbc, "wheels.dbc");
  const dbc::Message& m = db.messages.front();
  auto corner = [&](const char* name) {
    for (const auto& s : m.signals)
      if (s.name == name) return init_detail::WheelCorner(m, s);
    return -2;
  };
  EXPECT_EQ(corner("WheelSpeedFL"), 0);
  EXPECT_EQ(corner("ESP_Raddrehzahl_HR"), 3);
  EXPECT_EQ(corner("Radgeschw_links_vorne"), 0);
  EXPECT_EQ(corner("WheelSpeedRearRight"), 3);
  EXPECT_TRUE(init_detail::IsRpmUnit("1/min"));
  EXPECT_TRUE(init_detail::IsRpmUnit("U/min"));
  EXPECT_FALSE(init_detail::IsRpmUnit("km/h"));
  // CollectSignals keeps only messages with a role-like signal; every signal here varies.
  std::ostringstream log;
  for (int i = 0; i < 50; ++i) {
    log << "(" << 1000 + i << ".000000) can0 001#";
    for (int b = 0; b < 6; ++b) log << fmt::format("{:02X}", (i * (b + 3)) % 251);
    log << "0000\n";
  }
  const fs::path path = fs::path(NDSID_BINARY_DIR) / "tests" / "desk" / ("wheel_names." + std::to_string(::getpid()) + ".log");
  std::ofstream(path) << log.str();
  auto reader = can::OpenFrameLog(path.string());
  uint64_t frames = 0;
  bool truncated = false;
  const init_detail::BusData data = init_detail::CollectSignals(db, *reader, "", 1000, frames, truncated);
  std::vector<std::string> names;
  for (const auto& c : init_detail::Candidates(data, init_detail::RoleKind::kWheelSpeed, 32)) names.push_back(c.expression);
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"WHEELS.ESP_Raddrehzahl_HR", "WHEELS.Radgeschw_links_vorne",
                                             "WHEELS.WheelSpeedFL", "WHEELS.WheelSpeedRearRight"}));
  EXPECT_TRUE(init_detail::Candidates(data, init_detail::RoleKind::kSpeed, 32).empty());  // no wheel is the vehicle speed
  fs::remove(path);
}

// The real 2017 RAV4 segment (60 s of highway) with opendbc's Toyota DBC, against the hand-made
// config/rav4_2017.yaml.
TEST(VehicleInitRealData, FindsTheRav4RolesAndSplitSteeringAngle) {
  const std::string real = NDSID_REALDATA_DIR;
  const std::string log = real + "/comma2k19-rav4-2017-segment/derived/rav4_2017_segment40.candump.log";
  const std::string dbc = real + "/opendbc-dbc/toyota_new_mc_pt_generated.dbc";
  if (real.empty() || !fs::exists(log) || !fs::exists(dbc)) GTEST_SKIP() << "../shared/realdata absent: " << log;
  const dbc::Database db = dbc::ParseDbcFile(dbc);
  auto reader = can::OpenFrameLog(log);
  const InitResult r = ProposeVehicleConfig(db, *reader);
  ASSERT_TRUE(r.MandatoryFound());
  const RoleProposal* steer = r.Find(Role::kSteeringWheelAngle);
  EXPECT_TRUE(steer->multi_signal);
  EXPECT_EQ(steer->expression, "STEER_ANGLE_SENSOR.STEER_ANGLE + STEER_ANGLE_SENSOR.STEER_FRACTION");
  ExpectRole(r, Role::kSteeringWheelAngle, "STEER_ANGLE_SENSOR", "STEER_ANGLE", "deg", 1);
  ExpectRole(r, Role::kSpeed, "SPEED", "SPEED", "km/h", 1);
  ExpectRole(r, Role::kLateralAcceleration, "KINEMATICS", "ACCEL_Y", "m/s^2", -1);
  ExpectRole(r, Role::kYawRate, "KINEMATICS", "YAW_RATE", "deg/s", 1);
  EXPECT_EQ(r.bus, "can0");
  // The wheel speeds' mean, for the plausibility check of the speed.
  const RoleProposal* wheels = r.Find(Role::kWheelSpeed);
  ASSERT_NE(wheels, nullptr);
  EXPECT_EQ(wheels->unit, "km/h");
  for (const char* w : {"WHEEL_SPEED_FL", "WHEEL_SPEED_FR", "WHEEL_SPEED_RL", "WHEEL_SPEED_RR"})
    EXPECT_NE(wheels->expression.find(std::string("WHEEL_SPEEDS.") + w), std::string::npos) << wheels->expression;

  // The hand-made config agrees on every role it has (steering: its first signal).
  const config::Config hand = config::LoadConfig(std::string(NDSID_SOURCE_DIR) + "/config/rav4_2017.yaml");
  for (Role role : {Role::kSteeringWheelAngle, Role::kSpeed, Role::kLateralAcceleration, Role::kYawRate}) {
    const RoleProposal* p = r.Find(role);
    const config::RoleSignal* h = hand.role(role);
    ASSERT_NE(h, nullptr);
    EXPECT_EQ(h->ref.message, p->message) << config::RoleKey(role);
    EXPECT_EQ(h->ref.signal, p->signal) << config::RoleKey(role);
    EXPECT_DOUBLE_EQ(h->scale_to_si, p->sign * config::UnitToSi(role, p->unit)) << config::RoleKey(role);
  }
  // The role expression is written as such.
  const std::string yaml = VehicleConfigYaml(r, {"rav4", log, dbc, "test", "rav4", {}});
  EXPECT_NE(yaml.find("steering_wheel_angle: {expr: \"STEER_ANGLE_SENSOR.STEER_ANGLE + STEER_ANGLE_SENSOR.STEER_FRACTION\", "
                      "unit: deg, sign: 1, timeout_s: "),
            std::string::npos)
      << yaml;
}

// Other OEMs' buses (opendbc DBCs without cycle times), simulated with `bus.signals` mapping the
// simulator's quantities onto their signals and every other message sent as zeros, counters and
// checksums: init must pick the mapped signals among all others, with the DBC's units (GM sends
// the speed in mph and names the yaw rate's unit "grad/s", Hyundai gives the yaw rate and the
// speed no unit at all, VW splits steering and yaw rate into magnitude and sign, Honda has no
// yaw rate).
struct OtherBus {
  const char* dbc;
  const char* mapping;  // YAML lines under bus.signals
  const char* steer;
  const char* speed;
  const char* speed_unit;
  const char* lat;
  const char* yaw;
  const char* lat_unit = "m/s^2";
  const char* steer_expression = nullptr;  // when the role is a role expression
  const char* yaw_expression = nullptr;
};

void PrintTo(const OtherBus& b, std::ostream* os) { *os << b.dbc; }

class OpendbcBus : public ::testing::TestWithParam<OtherBus> {};

TEST_P(OpendbcBus, FindsTheMappedSignalsAmongAllOthers) {
  const OtherBus& b = GetParam();
  const std::string dbc_path = std::string(NDSID_REALDATA_DIR) + "/opendbc-dbc/" + b.dbc;
  if (std::string(NDSID_REALDATA_DIR).empty() || !fs::exists(dbc_path)) GTEST_SKIP() << "../shared/realdata absent: " << dbc_path;
  const std::string yaml = std::string("seed: 11\nduration: {hours: 0.12}\nbus:\n  default_cycle_ms: 200\n  signals:\n") + b.mapping;
  const config::SimulationConfig cfg = config::ParseSimulationConfig(yaml, "other_bus_sim.yaml");
  const dbc::Database db = dbc::ParseDbcFile(dbc_path);
  const fs::path dir = fs::path(NDSID_BINARY_DIR) / "tests" / "desk" / "vehicle_init_opendbc";
  fs::create_directories(dir);
  const std::string log = (dir / (fs::path(b.dbc).stem().string() + ".log")).string();
  {
    sim::CandumpLogWriter writer(db, cfg, log);
    sim::SimulateDrives(cfg, [&](sim::DriveResult&& d) { writer.WriteDrive(d); });
    writer.Close();
  }
  auto reader = can::OpenFrameLog(log);
  const InitResult r = ProposeVehicleConfig(db, *reader);
  ASSERT_TRUE(r.MandatoryFound()) << InitSummary(r);
  auto split = [](const std::string& ref) { return std::make_pair(ref.substr(0, ref.find('.')), ref.substr(ref.find('.') + 1)); };
  const auto [sm, ss] = split(b.steer);
  const auto [vm, vs] = split(b.speed);
  const auto [am, as] = split(b.lat);
  const auto [ym, ys] = split(b.yaw);
  ExpectRole(r, Role::kSteeringWheelAngle, sm, ss, "deg", 1);
  ExpectRole(r, Role::kSpeed, vm, vs, b.speed_unit, 1);
  ExpectRole(r, Role::kLateralAcceleration, am, as, b.lat_unit, 1);
  EXPECT_EQ(r.Find(Role::kSteeringWheelAngle)->expression, b.steer_expression ? b.steer_expression : b.steer);
  if (std::string(b.yaw).empty()) {  // no yaw rate on this bus: a_y = v^2 d_sw / (is l ...) instead, said so
    EXPECT_FALSE(r.Find(Role::kYawRate)->found);
    bool stated = false;
    for (const auto& n : r.notes) stated |= n.find("no yaw rate: ISO 8855 sign ASSUMED") != std::string::npos;
    EXPECT_TRUE(stated);
    EXPECT_LE(r.Find(Role::kSteeringWheelAngle)->confidence, 0.6);
    return;
  }
  ExpectRole(r, Role::kYawRate, ym, ys, "deg/s", 1);
  EXPECT_EQ(r.Find(Role::kYawRate)->expression, b.yaw_expression ? b.yaw_expression : b.yaw);
}

INSTANTIATE_TEST_SUITE_P(
    VehicleInit, OpendbcBus,
    ::testing::Values(
        OtherBus{"gm_global_a_powertrain.dbc",
                 "    steering_wheel_angle: PSCMSteeringAngle.SteeringWheelAngle\n"
                 "    steering_wheel_rate: PSCMSteeringAngle.SteeringWheelRate\n"
                 "    vehicle_speed: ECMVehicleSpeed.VehicleSpeed\n"
                 "    lateral_acceleration: EBCMVehicleDynamic.LateralAcceleration\n"
                 "    yaw_rate: EBCMVehicleDynamic.YawRate2\n"
                 "    wheel_speed_fl: EBCMWheelSpdFront.FLWheelSpd\n"
                 "    wheel_speed_fr: EBCMWheelSpdFront.FRWheelSpd\n"
                 "    wheel_speed_rl: EBCMWheelSpdRear.RLWheelSpd\n"
                 "    wheel_speed_rr: EBCMWheelSpdRear.RRWheelSpd\n",
                 "PSCMSteeringAngle.SteeringWheelAngle", "ECMVehicleSpeed.VehicleSpeed", "mph",
                 "EBCMVehicleDynamic.LateralAcceleration", "EBCMVehicleDynamic.YawRate2"},
        OtherBus{"hyundai_can.dbc",
                 "    steering_wheel_angle: SAS11.SAS_Angle\n"
                 "    steering_wheel_rate: SAS11.SAS_Speed\n"
                 "    vehicle_speed: CLU15.CF_Clu_VehicleSpeed\n"
                 "    lateral_acceleration: ESP12.LAT_ACCEL\n"
                 "    longitudinal_acceleration: ESP12.LONG_ACCEL\n"
                 "    yaw_rate: ESP12.YAW_RATE\n"
                 "    wheel_speed_fl: WHL_SPD11.WHL_SPD_FL\n"
                 "    wheel_speed_fr: WHL_SPD11.WHL_SPD_FR\n"
                 "    wheel_speed_rl: WHL_SPD11.WHL_SPD_RL\n"
                 "    wheel_speed_rr: WHL_SPD11.WHL_SPD_RR\n",
                 "SAS11.SAS_Angle", "CLU15.CF_Clu_VehicleSpeed", "km/h", "ESP12.LAT_ACCEL", "ESP12.YAW_RATE"},
        // VW sends steering and yaw rate as magnitude + sign bit, a_y in g, the speed named only
        // by its unit; the roles are role expressions.
        OtherBus{"vw_mqb.dbc",
                 "    steering_wheel_angle_magnitude: LWI_01.LWI_Lenkradwinkel\n"
                 "    steering_wheel_angle_negative: LWI_01.LWI_VZ_Lenkradwinkel\n"
                 "    vehicle_speed: ESP_21.ESP_v_Signal\n"
                 "    lateral_acceleration: ESP_02.ESP_Querbeschleunigung\n"
                 "    longitudinal_acceleration: ESP_02.ESP_Laengsbeschl\n"
                 "    yaw_rate_magnitude: ESP_02.ESP_Gierrate\n"
                 "    yaw_rate_negative: ESP_02.ESP_VZ_Gierrate\n",
                 "LWI_01.LWI_Lenkradwinkel", "ESP_21.ESP_v_Signal", "km/h", "ESP_02.ESP_Querbeschleunigung",
                 "ESP_02.ESP_Gierrate", "g",
                 "LWI_01.LWI_Lenkradwinkel * (1 - 2 * LWI_01.LWI_VZ_Lenkradwinkel)",
                 "ESP_02.ESP_Gierrate * (1 - 2 * ESP_02.ESP_VZ_Gierrate)"},
        // Honda's bus has no yaw rate at all, and three signals named LAT_ACCEL (KINEMATICS' cannot
        // carry a value: offset -512 with 10 bits of 0.02; it stays constant).
        OtherBus{"honda_civic_touring_2016_can_generated.dbc",
                 "    steering_wheel_angle: STEERING_SENSORS.STEER_ANGLE\n"
                 "    steering_wheel_rate: STEERING_SENSORS.STEER_ANGLE_RATE\n"
                 "    vehicle_speed: ENGINE_DATA.XMISSION_SPEED\n"
                 "    lateral_acceleration: VEHICLE_DYNAMICS.LAT_ACCEL\n"
                 "    longitudinal_acceleration: VEHICLE_DYNAMICS.LONG_ACCEL\n"
                 "    wheel_speed_fl: WHEEL_SPEEDS.WHEEL_SPEED_FL\n"
                 "    wheel_speed_fr: WHEEL_SPEEDS.WHEEL_SPEED_FR\n"
                 "    wheel_speed_rl: WHEEL_SPEEDS.WHEEL_SPEED_RL\n"
                 "    wheel_speed_rr: WHEEL_SPEEDS.WHEEL_SPEED_RR\n",
                 "STEERING_SENSORS.STEER_ANGLE", "ENGINE_DATA.XMISSION_SPEED", "km/h", "VEHICLE_DYNAMICS.LAT_ACCEL", ""}),
    [](const ::testing::TestParamInfo<OtherBus>& info) {
      return std::string(info.index == 0 ? "Gm" : info.index == 1 ? "Hyundai" : info.index == 2 ? "Vw" : "Honda");
    });

}  // namespace
}  // namespace ndsid::desk
