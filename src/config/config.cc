#include "ndsid/config/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "ndsid/common/atomic_file.h"
#include "ndsid/common/closest_match.h"
#include "ndsid/dbc/database.h"
#include "config_sections.h"
#include "yaml_reader.h"

namespace ndsid::config {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr size_t kMaxConfigBytes = 16 << 20;  // a vehicle YAML is a few kB

std::string FormatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

struct RoleInfo {
  const char* key;
  bool required;
  bool flag;
};
constexpr RoleInfo kRoles[kNumRoles] = {
    {"steering_wheel_angle", true, false},   {"vehicle_speed", true, false},
    {"lateral_acceleration", true, false},   {"yaw_rate", false, false},
    {"longitudinal_acceleration", false, false}, {"reverse_gear", false, true},
    {"esc_intervention", false, true},       {"wheel_speed", false, false},
    {"rear_wheel_speed_difference", false, false},
};

}  // namespace

const char* RoleKey(Role role) { return kRoles[static_cast<int>(role)].key; }
bool RoleIsRequired(Role role) { return kRoles[static_cast<int>(role)].required; }
bool RoleIsFlag(Role role) { return kRoles[static_cast<int>(role)].flag; }

bool RoleSignal::IsActive(double physical) const {
  return std::any_of(active_values.begin(), active_values.end(), [&](double a) { return std::abs(a - physical) < 1e-9; });
}

double UnitToSi(Role role, const std::string& unit) {
  struct Unit {
    const char* name;
    double to_si;
  };
  std::vector<Unit> units;
  switch (role) {
    case Role::kSteeringWheelAngle: units = {{"deg", kDegToRad}, {"rad", 1.0}}; break;
    case Role::kSpeed:
    case Role::kWheelSpeed:
    case Role::kRearWheelSpeedDifference: units = {{"km/h", 1.0 / 3.6}, {"kph", 1.0 / 3.6}, {"m/s", 1.0}, {"mph", 0.44704}}; break;
    case Role::kLateralAcceleration:
    case Role::kLongitudinalAcceleration: units = {{"m/s^2", 1.0}, {"m/s2", 1.0}, {"g", 9.81}}; break;
    case Role::kYawRate: units = {{"deg/s", kDegToRad}, {"rad/s", 1.0}}; break;
    default: return 1.0;
  }
  std::vector<std::string> names;
  for (const Unit& u : units) {
    if (unit == u.name) return u.to_si;
    names.emplace_back(u.name);
  }
  throw ConfigError("unknown unit '" + unit + "' for " + RoleKey(role) + AcceptedValuesHint(unit, names));
}

namespace {

YAML::Node LoadRoot(const std::string& yaml_text, const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(FormatLocation(path, e.mark.line + 1, e.mark.column + 1, "YAML syntax: " + e.msg));
  }
  if (!root || !root.IsMap()) throw ConfigError(FormatLocation(path, 1, 0, "expected a YAML mapping at the top"));
  return root;
}

// The sections in order (config_sections.h): an optional section keeps its defaults when absent.
Config ParseConfigText(const std::string& yaml_text, const std::string& path) {
  const YAML::Node root = LoadRoot(yaml_text, path);
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  const YamlReader top(root, path, "");
  Config c;
  c.path = path;
  ReadVehicle(top.Child("vehicle"), c.vehicle);
  if (c.vehicle.road_wheel_angle) {  // defaults for a road-wheel angle; gate and plausibility may set their own
    c.plausibility.steer_ratio_min = PlausibilityConfig::kRoadWheelSteerRatioMin;
    c.plausibility.steer_ratio_max = PlausibilityConfig::kRoadWheelSteerRatioMax;
    c.gate.quasi_steady_max_steer_rate_radps /= GateConfig::kTypicalSteerRatio;  // the same turn of the road wheels
  }
  ReadSource(top.Child("source"), base_dir, c.source);
  c.dbc = Resolve(base_dir, top.String("dbc"));
  ReadSignals(top.Child("signals"), c);
  if (top.Has("sync")) ReadSync(top.Child("sync"), c.sync);
  if (c.role(Role::kRearWheelSpeedDifference) && !(c.vehicle.track_rear_m > 0)) {
    top.Child("signals").Fail(RoleKey(Role::kRearWheelSpeedDifference),
                              "needs vehicle.track_rear_m (the rear track width [m], data sheet): the difference is r times it");
  }
  for (int i = 0; i < kNumRoles; ++i) {  // a low-pass needs a grid fast enough to run it
    if (c.roles[i] && c.roles[i]->lowpass_hz > c.sync.rate_hz / 4) {
      top.Child("signals").Child(RoleKey(static_cast<Role>(i)))
          .Fail("lowpass_hz", FormatNumber(c.roles[i]->lowpass_hz) + " Hz is above a quarter of sync.rate_hz (" +
                                  FormatNumber(c.sync.rate_hz) + " Hz)");
    }
  }
  if (top.Has("gate")) ReadGate(top.Child("gate"), c.gate);
  ReadIdentification(top.Has("identification") ? top.Child("identification") : YamlReader(YAML::Node(), path, "identification"),
                     base_dir, c.vehicle, c.role(Role::kYawRate) != nullptr, c.identification);
  if (top.Has("adequacy")) ReadAdequacy(top.Child("adequacy"), c.adequacy);
  if (top.Has("plausibility")) ReadPlausibility(top.Child("plausibility"), c.plausibility);
  if (top.Has("lcm")) ReadLcm(top.Child("lcm"), c.lcm);
  if (top.Has("model")) ReadModel(top.Child("model"), c);
  if (!c.identification.prior_from.empty()) ApplyFleetPrior(path, c.vehicle, c.identification);
  ReadTopLevel(top, base_dir, c);
  top.Finish();
  return c;
}

}  // namespace

Config ParseConfig(const std::string& yaml_text, const std::string& path) {
  try {
    return ParseConfigText(yaml_text, path);
  } catch (const YAML::Exception& e) {  // e.g. a complex key ("? [a, b]") read as a string
    throw ConfigError(FormatLocation(path, e.mark.line + 1, e.mark.column + 1, "YAML: " + e.msg));
  }
}

Config LoadConfig(const std::string& path) {
  std::string text;
  try {
    text = ReadWholeFile(path, kMaxConfigBytes);
  } catch (const Error& e) {
    throw ConfigError(e.what());
  }
  return ParseConfig(text, path);
}

void ValidateAgainstDbc(const Config& c, const dbc::Database& db) {
  auto check = [&](const SignalRef& ref, int line, const std::string& what) {
    const dbc::Message* m = db.FindMessage(ref.message);
    if (!m) {
      std::vector<std::string> names;
      for (const auto& msg : db.messages) names.push_back(msg.name);
      const std::string best = ClosestMatch(ref.message, names);
      throw ConfigError(FormatLocation(c.path, line, 0, what + ": message '" + ref.message + "' not in DBC " + db.file +
                                                            (best.empty() ? "" : "; did you mean '" + best + "'?")));
    }
    if (!m->FindSignal(ref.signal)) {
      std::vector<std::string> names;
      for (const auto& sig : m->signals) names.push_back(sig.name);
      throw ConfigError(FormatLocation(c.path, line, 0,
                                       what + ": signal '" + ref.signal + "' not in message '" + ref.message + "' of DBC " +
                                           db.file + AcceptedValuesHint(ref.signal, names)));
    }
  };
  for (int i = 0; i < kNumRoles; ++i) {
    if (!c.roles[i]) continue;
    const std::string what = std::string("signals.") + RoleKey(static_cast<Role>(i));
    if (c.roles[i]->expression) {
      for (const SignalRef& in : c.roles[i]->inputs) check(in, c.roles[i]->line, what + ".expr");
    } else {
      check(c.roles[i]->ref, c.roles[i]->line, what);
    }
  }
  for (const auto& v : c.validity) check(v.ref, v.line, "signals.validity");
}

}  // namespace ndsid::config
