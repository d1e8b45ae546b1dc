// Role expressions (docs/configuration.md, "Role expressions"): a role computed from several
// signals, evaluated by the RoleExtractor on frames encoded with the DBC encoder, read back on the
// sync grid. Cases of real buses: a coarse angle plus a fine remainder (Toyota), sign and magnitude
// in separate signals, a value chosen by a status signal, inputs in two messages (staleness).
#include "ndsid/sync/role_extractor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/encoder.h"

namespace ndsid::sync {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr double kDeg = M_PI / 180.0;

const char* kDbc = R"(VERSION ""
BU_: XXX
BO_ 37 STEER_ANGLE_SENSOR: 8 XXX
 SG_ STEER_ANGLE : 3|12@0- (1.5,0) [-1500|1500] "deg" XXX
 SG_ STEER_FRACTION : 39|4@0- (0.1,0) [-0.7|0.7] "deg" XXX
BO_ 48 SIGNMAG: 8 XXX
 SG_ ANGLE_SIGN : 0|1@1+ (1,0) [0|1] "" XXX
 SG_ ANGLE_MAG : 1|15@1+ (0.1,0) [0|3276] "deg" XXX
 SG_ STATUS : 16|2@1+ (1,0) [0|3] "" XXX
 SG_ ALT_ANGLE : 24|16@1- (0.1,0) [-3276|3276] "deg" XXX
BO_ 49 FINE: 8 XXX
 SG_ FINE_ANGLE : 0|8@1- (0.01,0) [-1.28|1.27] "deg" XXX
BO_ 64 SPEED: 8 XXX
 SG_ SPEED : 0|16@1+ (0.01,0) [0|655] "km/h" XXX
BO_ 80 ACC: 8 XXX
 SG_ AY : 0|16@1- (0.001,0) [-32|32] "m/s^2" XXX
)";

config::Config Config(const std::string& steering) {
  return config::ParseConfig(R"(vehicle: {name: car, wheelbase_m: 2.6, mass_kg: 1500}
source: {type: log, logs: [a.log]}
dbc: b.dbc
signals:
  steering_wheel_angle: )" + steering + R"(
  vehicle_speed: {message: SPEED, signal: SPEED, unit: km/h}
  lateral_acceleration: {message: ACC, signal: AY, unit: m/s^2}
sync: {rate_hz: 100, latency_s: 0.05, max_fill_gap_s: 1.0}
)",
                             "t.yaml");
}

struct Bus {
  dbc::Database db = dbc::ParseDbcText(kDbc, "t.dbc");
  can::CanFrame Frame(const std::string& message, int64_t t_ns, const std::vector<std::pair<std::string, double>>& values) const {
    const dbc::Message* m = db.FindMessage(message);
    can::CanFrame f;
    f.timestamp_ns = t_ns;
    f.id = m->id;
    f.len = 8;
    for (const auto& [name, v] : values) dbc::EncodeSignal(*m->FindSignal(name), v, {f.data.data(), 8});
    return f;
  }
};

// Drives 3 s at 100 Hz: speed and a_y plain, steering frames from `steer(t_ms, frames)`, and
// returns the valid samples after a 200 ms warm-up.
std::vector<Sample> Drive(const config::Config& cfg, const Bus& bus,
                          const std::function<void(int64_t, std::vector<can::CanFrame>&)>& steer, int64_t t_end_ms = 3000) {
  RoleExtractor ex(cfg, bus.db);
  SignalSync sync(cfg);
  std::vector<Sample> out;
  const std::vector<std::string> buses{"can0"};
  for (int64_t t = 0; t <= t_end_ms; t += 10) {
    std::vector<can::CanFrame> frames{bus.Frame("SPEED", t * kMs, {{"SPEED", 50.0}}), bus.Frame("ACC", t * kMs + kMs, {{"AY", 1.0}})};
    steer(t, frames);
    for (const auto& f : frames) {
      sync.Advance(f.timestamp_ns, out);
      ex.Process(f, buses, sync);
    }
  }
  sync.Flush(out);
  std::vector<Sample> valid;
  for (const Sample& s : out)
    if (s.valid && s.t_ns > 200 * kMs) valid.push_back(s);
  return valid;
}

// The steering angle a test drives: a slow sine of 40 deg amplitude (sign changes included).
double TrueAngleDeg(int64_t t_ms) { return 40.0 * std::sin(2 * M_PI * 0.5 * t_ms / 1000.0) + 0.37; }

// Catches: the fine part dropped (the 1.5-deg steps of the RAV4's coarse angle come back), or a
// sum evaluated from one frame's coarse and an older frame's fine value.
TEST(RoleExpression, CoarsePlusFineRemovesTheQuantisation) {
  const Bus bus;
  // Coarse to the nearest 1.5 deg, the remainder in the 4-bit fraction ([-0.8, 0.7] in 0.1 deg).
  auto toyota_exact = [&](int64_t t, std::vector<can::CanFrame>& frames) {
    const double a = TrueAngleDeg(t);
    const double coarse = 1.5 * std::round(a / 1.5);
    frames.push_back(bus.Frame("STEER_ANGLE_SENSOR", t * kMs + 2 * kMs, {{"STEER_ANGLE", coarse}, {"STEER_FRACTION", a - coarse}}));
  };
  const auto sum = Drive(Config("{expr: \"STEER_ANGLE_SENSOR.STEER_ANGLE + STEER_ANGLE_SENSOR.STEER_FRACTION\", unit: deg}"), bus, toyota_exact);
  const auto coarse = Drive(Config("{message: STEER_ANGLE_SENSOR, signal: STEER_ANGLE, unit: deg}"), bus, toyota_exact);
  ASSERT_GT(sum.size(), 250u);
  ASSERT_EQ(sum.size(), coarse.size());
  double max_sum = 0, max_coarse = 0;
  for (size_t i = 0; i < sum.size(); ++i) {
    // The sample at t is the steering frame sent at t - 8 ms interpolated; compare with the
    // encoded angle of the frames around it (1 decimal: the fraction's resolution).
    const int64_t t_ms = sum[i].t_ns / kMs;
    const double truth = TrueAngleDeg(t_ms - 2);  // the frame's content at its send time (t + 2 ms)
    max_sum = std::max(max_sum, std::abs(sum[i].steer_rad / kDeg - truth));
    max_coarse = std::max(max_coarse, std::abs(coarse[i].steer_rad / kDeg - truth));
  }
  EXPECT_LT(max_sum, 0.06) << "sum of coarse and fine within the fine resolution";
  EXPECT_GT(max_coarse, 0.6) << "the coarse signal alone is quantised to 1.5 deg";
}

// Catches: sign and magnitude combined the wrong way round, or a select() reading its branches
// swapped; the two spellings must agree.
TEST(RoleExpression, SignAndMagnitudeBothSpellingsAgree) {
  const Bus bus;
  auto signmag = [&](int64_t t, std::vector<can::CanFrame>& frames) {
    const double a = TrueAngleDeg(t);
    frames.push_back(bus.Frame("SIGNMAG", t * kMs + 2 * kMs, {{"ANGLE_SIGN", a < 0 ? 1.0 : 0.0}, {"ANGLE_MAG", std::abs(a)}}));
  };
  const auto product = Drive(Config("{expr: \"(1 - 2 * SIGNMAG.ANGLE_SIGN) * SIGNMAG.ANGLE_MAG\", unit: deg}"), bus, signmag);
  const auto select =
      Drive(Config("{expr: \"select(SIGNMAG.ANGLE_SIGN == 1, -SIGNMAG.ANGLE_MAG, SIGNMAG.ANGLE_MAG)\", unit: deg}"), bus, signmag);
  ASSERT_GT(product.size(), 250u);
  ASSERT_EQ(product.size(), select.size());
  int negative = 0;
  for (size_t i = 0; i < product.size(); ++i) {
    const double truth = TrueAngleDeg(product[i].t_ns / kMs - 2);
    EXPECT_NEAR(product[i].steer_rad / kDeg, truth, 0.06) << i;
    EXPECT_DOUBLE_EQ(product[i].steer_rad, select[i].steer_rad) << i;
    negative += truth < -1;
  }
  EXPECT_GT(negative, 50) << "the drive steers to both sides";
}

// Catches: a status signal ignored (the fallback angle never used) or the role's sign and unit
// applied before the expression instead of after it.
TEST(RoleExpression, SelectByStatusThenUnitAndSign) {
  const Bus bus;
  // STATUS 0: ANGLE_MAG/ANGLE_SIGN valid; STATUS 2: only ALT_ANGLE valid (the other is garbage).
  auto with_status = [&](int64_t t, std::vector<can::CanFrame>& frames) {
    const double a = TrueAngleDeg(t);
    const bool alt = (t / 500) % 2 == 1;
    frames.push_back(bus.Frame("SIGNMAG", t * kMs + 2 * kMs,
                               {{"STATUS", alt ? 2.0 : 0.0},
                                {"ANGLE_SIGN", a < 0 ? 1.0 : 0.0},
                                {"ANGLE_MAG", alt ? 999.0 : std::abs(a)},
                                {"ALT_ANGLE", alt ? a : -777.0}}));
  };
  const auto got = Drive(
      Config("{expr: \"select(SIGNMAG.STATUS >= 2, SIGNMAG.ALT_ANGLE, sgn(0.5 - SIGNMAG.ANGLE_SIGN) * SIGNMAG.ANGLE_MAG)\", unit: deg, sign: -1}"),
      bus, with_status);
  ASSERT_GT(got.size(), 250u);
  for (const Sample& s : got) {
    const int64_t t_ms = s.t_ns / kMs - 2;
    // Skip the interpolation across a status switch (two sources, both right, but 10 ms apart).
    if (t_ms % 500 < 20 || t_ms % 500 > 480) continue;
    EXPECT_NEAR(s.steer_rad / kDeg, -TrueAngleDeg(t_ms), 0.06) << t_ms;
  }
}

// Catches: an expression evaluated with an input that stopped coming (its last value reused
// forever), or not evaluated at all when its inputs sit in different messages.
TEST(RoleExpression, InputsInTwoMessagesAndStaleness) {
  const Bus bus;
  // The angle less a trim in one message, the trim in another (which stops at 1.5 s).
  auto two = [&](int64_t t, std::vector<can::CanFrame>& frames) {
    frames.push_back(bus.Frame("SIGNMAG", t * kMs + 2 * kMs, {{"ALT_ANGLE", TrueAngleDeg(t) - 0.83}}));
    if (t < 1500) frames.push_back(bus.Frame("FINE", t * kMs + 5 * kMs, {{"FINE_ANGLE", 0.83}}));
  };
  const auto cfg = Config("{expr: \"SIGNMAG.ALT_ANGLE + FINE.FINE_ANGLE\", unit: deg, timeout_s: 0.1}");
  const auto got = Drive(cfg, bus, two);
  ASSERT_GT(got.size(), 100u);
  int64_t last_ms = 0;
  for (const Sample& s : got) {
    const int64_t t_ms = s.t_ns / kMs;
    last_ms = std::max(last_ms, t_ms);
    // Evaluated while the trim is at most 0.1 s old (then the sync stage holds the last value
    // for the role's timeout).
    if (t_ms < 1590) EXPECT_NEAR(s.steer_rad / kDeg, TrueAngleDeg(t_ms - 2), 0.06) << t_ms;
  }
  // Trim last sent at 1495 ms: evaluated until 1595 ms, held until 1695 ms, then stale.
  EXPECT_GT(last_ms, 1580) << "evaluated with a trim up to timeout_s old";
  EXPECT_LT(last_ms, 1750) << "steering became stale once the trim stopped";
}

// Catches: a division by zero on the bus published as an infinite steering angle.
TEST(RoleExpression, NonFiniteResultGivesNoValue) {
  const Bus bus;
  auto zero_after_1s = [&](int64_t t, std::vector<can::CanFrame>& frames) {
    frames.push_back(bus.Frame("SIGNMAG", t * kMs + 2 * kMs, {{"ALT_ANGLE", 10.0}, {"ANGLE_MAG", t < 1000 ? 2.0 : 0.0}}));
  };
  const auto got = Drive(Config("{expr: \"SIGNMAG.ALT_ANGLE / SIGNMAG.ANGLE_MAG\", unit: deg}"), bus, zero_after_1s);
  ASSERT_GT(got.size(), 50u);
  for (const Sample& s : got) {
    EXPECT_TRUE(std::isfinite(s.steer_rad));
    EXPECT_NEAR(s.steer_rad / kDeg, 5.0, 1e-9);
    EXPECT_LT(s.t_ns / kMs, 1000 + 250);
  }
}

std::string ConfigError(const std::string& steering) {
  try {
    const Bus bus;
    const auto cfg = Config(steering);
    RoleExtractor ex(cfg, bus.db);
  } catch (const ndsid::ConfigError& e) {
    return e.what();
  }
  return "no error";
}

// Catches: a mistyped input accepted (the role never gets a value, silently), or an error that
// does not say where or what to write instead.
TEST(RoleExpression, MistakesAreLocated) {
  const std::string unknown_signal = ConfigError("{expr: \"STEER_ANGLE_SENSOR.STEER_ANGEL + 1\", unit: deg}");
  EXPECT_NE(unknown_signal.find("t.yaml:5"), std::string::npos) << unknown_signal;
  EXPECT_NE(unknown_signal.find("signals.steering_wheel_angle.expr"), std::string::npos) << unknown_signal;
  EXPECT_NE(unknown_signal.find("did you mean 'STEER_ANGLE'"), std::string::npos) << unknown_signal;

  const std::string unknown_message = ConfigError("{expr: \"STEER_ANGEL_SENSOR.STEER_ANGLE\", unit: deg}");
  EXPECT_NE(unknown_message.find("did you mean 'STEER_ANGLE_SENSOR'"), std::string::npos) << unknown_message;

  const std::string both = ConfigError("{expr: \"FINE.FINE_ANGLE\", message: FINE, signal: FINE_ANGLE, unit: deg}");
  EXPECT_NE(both.find("not both"), std::string::npos) << both;

  const std::string syntax = ConfigError("{expr: \"FINE.FINE_ANGLE + * 2\", unit: deg}");
  EXPECT_NE(syntax.find("column"), std::string::npos) << syntax;
  EXPECT_NE(syntax.find("t.yaml:5"), std::string::npos) << syntax;

  const std::string no_signal = ConfigError("{expr: \"2 * 3\", unit: deg}");
  EXPECT_NE(no_signal.find("names no signal"), std::string::npos) << no_signal;

  const std::string function = ConfigError("{expr: \"sign(FINE.FINE_ANGLE)\", unit: deg}");
  EXPECT_NE(function.find("unknown function 'sign'"), std::string::npos) << function;

  EXPECT_EQ(ConfigError("{expr: \"FINE.FINE_ANGLE * 2\", unit: deg}"), "no error");
}

}  // namespace
}  // namespace ndsid::sync
