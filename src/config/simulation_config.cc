// YAML loading of the simulator configuration (config/sim_*.yaml).
#include "ndsid/config/simulation_config.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <map>
#include <sstream>

#include "ndsid/common/atomic_file.h"
#include "ndsid/common/error.h"

namespace ndsid::config {

bool SimEffects::any() const {
  for (const auto& e : EffectTable()) {
    if (this->*e.field != 0.0 && std::string_view(e.name) != "roll_frequency_hz" &&
        std::string_view(e.name) != "roll_damping_ratio")
      return true;
  }
  return !mass_schedule_kg.empty();
}

const std::vector<EffectInfo>& EffectTable() {
  static const std::vector<EffectInfo> table = {
      {"accel_bias_mps2", "m/s^2", "accelerometer bias: a_y,meas = a_y + b", "+-0.1", &SimEffects::accel_bias_mps2},
      {"steer_offset_deg", "deg", "steering-angle sensor offset at the wheel: d_sw,meas = d_sw,true + d0", "+-2",
       &SimEffects::steer_offset_deg},
      {"roll_gradient_deg_per_g", "deg/g", "body roll, 2nd-order roll mode: a_y,meas = a_y + g*phi", "3..7",
       &SimEffects::roll_gradient_deg_per_g},
      {"roll_frequency_hz", "Hz", "roll eigenfrequency (with roll_gradient_deg_per_g)", "1.5",
       &SimEffects::roll_frequency_hz},
      {"roll_damping_ratio", "-", "roll damping ratio (with roll_gradient_deg_per_g)", "0.5",
       &SimEffects::roll_damping_ratio},
      {"superelevation_pct", "%", "road banked into curves (max), force in the dynamics and on the accelerometer",
       "0..6", &SimEffects::superelevation_pct},
      {"lever_arm_m", "m", "accelerometer x_s ahead of the CG: a_y,meas = a_y + x_s*r'", "-1..1",
       &SimEffects::lever_arm_m},
      {"tyre_mu", "-", "tyre saturation F = D*tanh(c*alpha/D), D = mu*Fz per axle (0 = linear)", "0.7..1.0",
       &SimEffects::tyre_mu},
      {"rear_stiffness_speed_pct", "%",
       "rear cornering stiffness rising with speed (aerodynamic downforce; outside the model library): "
       "ch(v) = ch (1 + k (v / 30 m/s)^2), k here",
       "0..30", &SimEffects::rear_stiffness_speed_pct},
      {"steer_deadband_deg", "deg",
       "on-centre free play of the steering (outside the model library): the road wheels follow "
       "d_sw - clip(d_sw, -b, b), b at the steering wheel; negative: a lead (preload), d_sw + clip(d_sw, -|b|, |b|)",
       "0.5..3, -2..-0.5", &SimEffects::steer_deadband_deg},
      {"steer_asymmetry_pct", "%",
       "steering unequal left and right (outside the model library): the road wheels follow d_sw (1 + k sgn d_sw)",
       "+-5", &SimEffects::steer_asymmetry_pct},
      {"rear_steer_pct", "%",
       "active rear steering (a chassis system outside the model library): the rear wheels steer "
       "delta_h = k ((v / 30 m/s)^2 - 1/4) delta, against the front below 15 m/s, with it above; k here",
       "10..30", &SimEffects::rear_steer_pct},
      {"relaxation_length_m", "m", "tyre relaxation: slip angle lags with tau = sigma/v", "0.3..1",
       &SimEffects::relaxation_length_m},
      {"steer_delay_ms", "ms", "steering message carries d_sw from dt earlier than the accelerometer", "20..150",
       &SimEffects::steer_delay_ms},
      {"speed_scale_pct", "%", "speed scale error v_meas = (1 + eps) v", "+-3", &SimEffects::speed_scale_pct},
      {"speed_offset_kph", "km/h", "speed signal offset v_meas = (1 + eps) v + c while moving (the vehicle speed only)", "+-2",
       &SimEffects::speed_offset_kph},
      {"speed_delay_ms", "ms", "speed signal latency (exact delay): v_meas(t) from v(t - tau)", "20..300",
       &SimEffects::speed_delay_ms},
      {"gyro_offset_degps", "deg/s", "yaw-rate sensor offset: r_meas = r + r0", "+-0.5",
       &SimEffects::gyro_offset_degps},
      {"gyro_offset_drive_degps", "deg/s", "per-drive yaw-rate sensor offset: r0_i = r0 + U(-d, d) for drive i", "0..0.5",
       &SimEffects::gyro_offset_drive_degps},
      {"gyro_scale_pct", "%", "yaw-rate sensor scale error: r_meas = (1 + k_r) r", "+-3", &SimEffects::gyro_scale_pct},
      {"accel_scale_pct", "%", "accelerometer scale error: a_y,meas = (1 + k_a) a_y", "+-3", &SimEffects::accel_scale_pct},
      {"accel_quadratic_pct", "%",
       "accelerometer nonlinearity, even (outside the model library): a_y,meas = q + k2 q^2/g on what it senses, "
       "k2 here (the reading's error at 1 g in % of g)",
       "+-5", &SimEffects::accel_quadratic_pct},
      {"gyro_delay_ms", "ms", "yaw-rate sensor latency (exact delay): r_meas(t) = r(t - tau)", "10..100",
       &SimEffects::gyro_delay_ms},
      {"accel_delay_ms", "ms", "accelerometer latency (exact delay of everything it senses)", "10..100",
       &SimEffects::accel_delay_ms},
      {"mass_change_kg", "kg", "per-drive mass m_i = m + U(-dm, dm), Jz scaled by m_i/m", "0..300",
       &SimEffects::mass_change_kg},
      {"accel_vibration_mps2", "m/s^2", "RMS of a 15..35 Hz vibration on the accelerometer while moving (a raw IMU on a stiff mount)",
       "1..7", &SimEffects::accel_vibration_mps2},
      {"gyro_vibration_degps", "deg/s", "RMS of a 15..35 Hz vibration on the gyro while moving", "0.5..5",
       &SimEffects::gyro_vibration_degps},
      {"rear_wheel_radius_diff_pct", "%",
       "rear right tyre's rolling radius above the rear left's (wear, pressure): its wheel speed reads v/(1 + d)", "+-1",
       &SimEffects::rear_wheel_radius_diff_pct},
      {"wheel_radius_load_pct_per_g", "%/g",
       "rolling radius falling with the lateral load transfer: the outer wheels read (1 + c a_y/g), the inner (1 - c a_y/g)",
       "0..1", &SimEffects::wheel_radius_load_pct_per_g},
  };
  return table;
}

void ApplyEffect(SimEffects& effects, std::string_view assignment) {
  const auto eq = assignment.find('=');
  std::string known;
  for (const auto& e : EffectTable()) known += std::string(known.empty() ? "" : ", ") + e.name;
  if (eq == std::string_view::npos)
    throw ConfigError("--effect '" + std::string(assignment) + "': expected name=value (names: " + known + ")");
  const std::string name(assignment.substr(0, eq));
  const std::string value_text(assignment.substr(eq + 1));
  for (const auto& e : EffectTable()) {
    if (name != e.name) continue;
    std::istringstream in(value_text);
    double value = 0.0;
    in >> value;
    if (!in || !in.eof() || !std::isfinite(value))
      throw ConfigError("--effect '" + std::string(assignment) + "': '" + value_text + "' is not a number");
    effects.*e.field = value;
    return;
  }
  throw ConfigError("--effect '" + std::string(assignment) + "': unknown effect '" + name + "' (known: " + known + ")");
}

namespace {

// Reads one mapping: each key has a setter; unknown keys throw with their position.
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string path, const std::string& file)
      : node_(node), path_(std::move(path)), file_(file) {
    if (node_ && !node_.IsMap()) Fail(node_, "expected a mapping");
  }
  void Number(const char* key, double& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      out = FiniteNumber(v, std::string("expected a number for ") + path_ + key, path_ + key);
    };
  }
  void Integer(const char* key, int& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      try {
        out = v.as<int>();
      } catch (const YAML::Exception&) {
        Fail(v, std::string("expected an integer for ") + path_ + key);
      }
    };
  }
  void Int64(const char* key, int64_t& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      try {
        out = v.as<int64_t>();
      } catch (const YAML::Exception&) {
        Fail(v, std::string("expected an integer for ") + path_ + key);
      }
    };
  }
  void Uint64(const char* key, uint64_t& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      try {
        out = v.as<uint64_t>();
      } catch (const YAML::Exception&) {
        Fail(v, std::string("expected a non-negative integer for ") + path_ + key);
      }
    };
  }
  void Text(const char* key, std::string& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      if (v.IsNull()) out.clear();
      else if (!v.IsScalar()) Fail(v, std::string("expected a text for ") + path_ + key);
      else out = v.Scalar();
    };
  }
  void NumberList(const char* key, std::vector<double>& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      if (!v.IsSequence()) Fail(v, std::string("expected a list of numbers for ") + path_ + key);
      out.clear();
      for (const auto& item : v) {
        try {
          out.push_back(item.as<double>());
        } catch (const YAML::Exception&) {
          Fail(item, std::string("expected a number in ") + path_ + key);
        }
      }
    };
  }
  // A mapping of free names (e.g. DBC messages) to numbers.
  void NumberMap(const char* key, std::map<std::string, double>& out) {
    handlers_[key] = [this, &out, key](const YAML::Node& v) {
      if (!v.IsMap()) Fail(v, std::string("expected a mapping of names to numbers for ") + path_ + key);
      out.clear();
      for (const auto& kv : v)
        out[KeyOf(kv.first)] = FiniteNumber(kv.second, std::string("expected a number in ") + path_ + key, path_ + key);
    };
  }
  void Map(const char* key, std::function<void(MapReader&)> fill) {
    handlers_[key] = [this, fill, key](const YAML::Node& v) {
      MapReader sub(v, path_ + key + ".", file_);
      fill(sub);
      sub.Run();
    };
  }
  void Run() {
    if (!node_ || node_.IsNull()) return;
    for (const auto& kv : node_) {
      const std::string key = KeyOf(kv.first);
      const auto it = handlers_.find(key);
      if (it == handlers_.end()) Fail(kv.first, "unknown key '" + path_ + key + "'");
      it->second(kv.second);
    }
  }
  // A finite number, else a located error: `expected` when it is not a number, "not finite: <where>".
  double FiniteNumber(const YAML::Node& v, const std::string& expected, const std::string& where) const {
    double x = 0;
    try {
      x = v.as<double>();
    } catch (const YAML::Exception&) {
      Fail(v, expected);
    }
    if (!std::isfinite(x)) Fail(v, "not finite: " + where);
    return x;
  }
  // A mapping's key as text (a sequence or mapping as a key is an error at its place).
  std::string KeyOf(const YAML::Node& k) const {
    if (!k.IsScalar()) Fail(k, "expected a text key in " + (path_.empty() ? std::string("the file") : path_));
    return k.Scalar();
  }
  [[noreturn]] void Fail(const YAML::Node& at, const std::string& message) const {
    const YAML::Mark m = at.Mark();
    throw ConfigError(FormatLocation(file_, m.line + 1, m.column + 1, message));
  }

 private:
  YAML::Node node_;
  std::string path_;
  const std::string& file_;
  std::map<std::string, std::function<void(const YAML::Node&)>> handlers_;
};

}  // namespace

const std::vector<std::string>& SimBusQuantities() {
  static const std::vector<std::string> q = {
      "steering_wheel_angle", "steering_wheel_rate", "vehicle_speed", "lateral_acceleration",
      "longitudinal_acceleration", "yaw_rate", "wheel_speed_fl", "wheel_speed_fr", "wheel_speed_rl",
      "wheel_speed_rr", "valid", "esc_intervention", "reverse_gear",
      // a bus that sends sign and magnitude apart (VW): |value| and 1 while the ISO value is negative
      "steering_wheel_angle_magnitude", "steering_wheel_angle_negative", "yaw_rate_magnitude", "yaw_rate_negative"};
  return q;
}

SimulationConfig ParseSimulationConfig(std::string_view yaml_text, const std::string& file_name) {
  SimulationConfig c;
  c.source_file = file_name;
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::ParserException& e) {
    throw ConfigError(FormatLocation(file_name, e.mark.line + 1, e.mark.column + 1, e.msg));
  }
  MapReader r(root, "", file_name);
  r.Uint64("seed", c.seed);
  r.Int64("start_epoch_s", c.start_epoch_s);
  r.Text("bus_name", c.bus_name);
  r.Map("vehicle", [&](MapReader& m) {
    auto& v = c.vehicle;
    m.Number("mass_kg", v.mass_kg);
    m.Number("yaw_inertia_kgm2", v.yaw_inertia_kgm2);
    m.Number("cornering_stiffness_front_npr", v.cornering_stiffness_front_npr);
    m.Number("cornering_stiffness_rear_npr", v.cornering_stiffness_rear_npr);
    m.Number("cg_to_front_m", v.cg_to_front_m);
    m.Number("wheelbase_m", v.wheelbase_m);
    m.Number("steering_ratio", v.steering_ratio);
    m.Number("track_width_m", v.track_width_m);
  });
  r.Map("duration", [&](MapReader& m) {
    auto& d = c.duration;
    m.Number("hours", d.hours);
    m.Integer("drives", d.drives);
    m.Number("short_drive_fraction", d.short_drive_fraction);
    m.Number("min_km", d.min_km);
    m.Number("max_km", d.max_km);
    m.Number("gap_min_h", d.gap_min_h);
    m.Number("gap_max_h", d.gap_max_h);
  });
  r.Map("integration", [&](MapReader& m) {
    m.Number("step_hz", c.integration.step_hz);
    m.Number("kinematic_below_mps", c.integration.kinematic_below_mps);
    m.Number("dynamic_above_mps", c.integration.dynamic_above_mps);
  });
  r.Map("road", [&](MapReader& m) {
    m.Number("crossfall_pct_max", c.road.crossfall_pct_max);
    m.Number("crossfall_correlation_m", c.road.crossfall_correlation_m);
    m.Number("evasive_per_hour", c.road.evasive_per_hour);
    m.Integer("parking_turns", c.road.parking_turns);
  });
  r.Map("drivers", [&](MapReader& m) {
    auto& d = c.drivers;
    m.Integer("count", d.count);
    m.Number("lat_accel_comfort_min_mps2", d.lat_accel_comfort_min_mps2);
    m.Number("lat_accel_comfort_max_mps2", d.lat_accel_comfort_max_mps2);
    m.Number("belief_error_pct", d.belief_error_pct);
    m.Number("steer_noise_deg", d.steer_noise_deg);
  });
  r.Map("noise", [&](MapReader& m) {
    auto& n = c.noise;
    m.Number("steer_deg", n.steer_deg);
    m.Number("speed_kph", n.speed_kph);
    m.Number("lat_accel_mps2", n.lat_accel_mps2);
    m.Number("long_accel_mps2", n.long_accel_mps2);
    m.Number("yaw_rate_degps", n.yaw_rate_degps);
    m.Number("lat_accel_disturbance_mps2", n.lat_accel_disturbance_mps2);
    m.Number("lat_accel_disturbance_tau_s", n.lat_accel_disturbance_tau_s);
  });
  r.Map("bus", [&](MapReader& m) {
    m.Number("default_cycle_ms", c.bus.default_cycle_ms);
    m.Number("signal_cycle_ms", c.bus.signal_cycle_ms);
    m.NumberMap("message_cycle_ms", c.bus.message_cycle_ms);
    m.Number("frame_loss_pct", c.bus.frame_loss_pct);
    m.Map("signals", [&](MapReader& sig) {
      for (const auto& q : SimBusQuantities()) sig.Text(q.c_str(), c.bus.signals[q]);
    });
  });
  r.Map("effects", [&](MapReader& m) {
    for (const auto& e : EffectTable()) m.Number(e.name, c.effects.*e.field);
    m.NumberList("mass_schedule_kg", c.effects.mass_schedule_kg);
  });
  try {
    r.Run();
  } catch (const YAML::Exception& e) {  // a conversion no handler anticipated: located all the same
    throw ConfigError(FormatLocation(file_name, e.mark.line + 1, e.mark.column + 1, e.msg));
  }
  for (auto it = c.bus.signals.begin(); it != c.bus.signals.end();) it = it->second.empty() ? c.bus.signals.erase(it) : std::next(it);
  ValidateSimulationConfig(c);
  return c;
}

SimulationConfig LoadSimulationConfig(const std::string& path) {
  std::string text;
  try {
    text = ReadWholeFile(path);
  } catch (const Error& e) {
    throw ConfigError(e.what());
  }
  return ParseSimulationConfig(text, path);
}

void ValidateSimulationConfig(const SimulationConfig& c) {
  const std::string where = c.source_file.empty() ? std::string("simulation config") : c.source_file;
  auto require = [&](bool ok, const std::string& what) {
    if (!ok) throw ConfigError(where + ": " + what);
  };
  require(c.bus.default_cycle_ms >= 0 && c.bus.default_cycle_ms <= 10000, "bus.default_cycle_ms must be in 0..10000");
  require(c.bus.signal_cycle_ms >= 10 && c.bus.signal_cycle_ms <= 10000, "bus.signal_cycle_ms must be in 10..10000");
  for (const auto& [name, ms] : c.bus.message_cycle_ms)
    require(ms >= 10 && ms <= 10000, "bus.message_cycle_ms." + name + " must be in 10..10000");
  require(c.bus.frame_loss_pct >= 0 && c.bus.frame_loss_pct <= 50, "bus.frame_loss_pct must be in 0..50");
  for (const auto& [q, ref] : c.bus.signals) {
    const auto dot = ref.find('.');
    require(dot != std::string::npos && dot > 0 && dot + 1 < ref.size(), "bus.signals." + q + ": expected MESSAGE.SIGNAL, got '" + ref + "'");
  }
  const auto& v = c.vehicle;
  require(v.mass_kg > 100.0 && v.mass_kg < 50000.0, "vehicle.mass_kg must be in (100, 50000) kg");
  require(v.yaw_inertia_kgm2 > 0.0, "vehicle.yaw_inertia_kgm2 must be > 0");
  require(v.cornering_stiffness_front_npr > 0.0 && v.cornering_stiffness_rear_npr > 0.0,
          "vehicle.cornering_stiffness_*_npr must be > 0");
  require(v.wheelbase_m > 0.5 && v.wheelbase_m < 10.0, "vehicle.wheelbase_m must be in (0.5, 10) m");
  require(v.cg_to_front_m > 0.0 && v.cg_to_front_m < v.wheelbase_m, "vehicle.cg_to_front_m must be in (0, wheelbase_m)");
  require(v.steering_ratio > 1.0 && v.steering_ratio < 50.0, "vehicle.steering_ratio must be in (1, 50)");
  require(v.track_width_m > 0.5 && v.track_width_m < 3.0, "vehicle.track_width_m must be in (0.5, 3) m");
  require(c.integration.step_hz >= 100.0 && c.integration.step_hz <= 100000.0 &&
              std::fabs(std::round(c.integration.step_hz / 100.0) * 100.0 - c.integration.step_hz) < 1e-9,
          "integration.step_hz must be a multiple of 100 Hz, >= 100 (RK4 step; output is 100 Hz)");
  require(c.integration.kinematic_below_mps > 0.2 && c.integration.dynamic_above_mps > c.integration.kinematic_below_mps,
          "integration: need 0.2 < kinematic_below_mps < dynamic_above_mps");
  require(c.duration.drives > 0 || c.duration.hours > 0.0, "duration: hours > 0 or drives > 0");
  require(c.duration.min_km > 0.0 && c.duration.max_km >= c.duration.min_km, "duration: 0 < min_km <= max_km");
  require(c.duration.short_drive_fraction >= 0.0 && c.duration.short_drive_fraction <= 1.0,
          "duration.short_drive_fraction must be in [0, 1]");
  require(c.duration.gap_min_h > 0.0 && c.duration.gap_max_h >= c.duration.gap_min_h,
          "duration: 0 < gap_min_h <= gap_max_h");
  require(c.drivers.count >= 1 && c.drivers.count <= 100, "drivers.count must be in [1, 100]");
  require(c.drivers.lat_accel_comfort_min_mps2 > 0.3 &&
              c.drivers.lat_accel_comfort_max_mps2 >= c.drivers.lat_accel_comfort_min_mps2,
          "drivers: 0.3 < lat_accel_comfort_min_mps2 <= lat_accel_comfort_max_mps2");
  require(c.road.crossfall_pct_max >= 0.0 && c.road.crossfall_pct_max <= 10.0, "road.crossfall_pct_max in [0, 10] %");
  require(c.road.crossfall_correlation_m > 1.0, "road.crossfall_correlation_m must be > 1 m");
  require(c.road.parking_turns >= 0 && c.road.parking_turns <= 20, "road.parking_turns in [0, 20]");
  const auto& n = c.noise;
  require(n.steer_deg >= 0 && n.speed_kph >= 0 && n.lat_accel_mps2 >= 0 && n.long_accel_mps2 >= 0 &&
              n.yaw_rate_degps >= 0 && n.lat_accel_disturbance_mps2 >= 0,
          "noise: standard deviations must be >= 0");
  require(n.lat_accel_disturbance_tau_s > 0.0, "noise.lat_accel_disturbance_tau_s must be > 0");
  const auto& e = c.effects;
  require(e.tyre_mu >= 0.0 && e.tyre_mu <= 2.0, "effects.tyre_mu must be in [0, 2] (0 = linear tyres)");
  require(e.relaxation_length_m >= 0.0 && e.relaxation_length_m <= 5.0, "effects.relaxation_length_m in [0, 5] m");
  require(e.rear_stiffness_speed_pct >= -50.0 && e.rear_stiffness_speed_pct <= 200.0,
          "effects.rear_stiffness_speed_pct in [-50, 200] %");
  require(e.steer_deadband_deg >= -30.0 && e.steer_deadband_deg <= 30.0, "effects.steer_deadband_deg in [-30, 30] deg");
  require(e.steer_asymmetry_pct >= -30.0 && e.steer_asymmetry_pct <= 30.0, "effects.steer_asymmetry_pct in [-30, 30] %");
  require(e.rear_steer_pct >= -100.0 && e.rear_steer_pct <= 100.0, "effects.rear_steer_pct in [-100, 100] %");
  require(e.steer_delay_ms >= 0.0 && e.steer_delay_ms <= 1000.0, "effects.steer_delay_ms in [0, 1000] ms");
  require(e.roll_frequency_hz > 0.2 && e.roll_frequency_hz < 10.0, "effects.roll_frequency_hz in (0.2, 10) Hz");
  require(e.roll_damping_ratio > 0.05 && e.roll_damping_ratio < 3.0, "effects.roll_damping_ratio in (0.05, 3)");
  require(std::fabs(e.superelevation_pct) <= 15.0, "effects.superelevation_pct in [-15, 15] %");
  require(std::fabs(e.speed_scale_pct) < 50.0, "effects.speed_scale_pct in (-50, 50) %");
  require(std::fabs(e.speed_offset_kph) <= 20.0, "effects.speed_offset_kph in [-20, 20] km/h");
  require(e.speed_delay_ms >= 0.0 && e.speed_delay_ms <= 1000.0, "effects.speed_delay_ms in [0, 1000] ms");
  require(std::fabs(e.gyro_offset_degps) <= 10.0, "effects.gyro_offset_degps in [-10, 10] deg/s");
  require(e.gyro_offset_drive_degps >= 0.0 && e.gyro_offset_drive_degps <= 10.0,
          "effects.gyro_offset_drive_degps in [0, 10] deg/s (a +- range)");
  require(std::fabs(e.gyro_scale_pct) < 50.0, "effects.gyro_scale_pct in (-50, 50) %");
  require(std::fabs(e.accel_scale_pct) < 50.0, "effects.accel_scale_pct in (-50, 50) %");
  require(std::fabs(e.accel_quadratic_pct) <= 30.0, "effects.accel_quadratic_pct in [-30, 30] %");
  require(std::fabs(e.rear_wheel_radius_diff_pct) <= 10.0, "effects.rear_wheel_radius_diff_pct in [-10, 10] %");
  require(std::fabs(e.wheel_radius_load_pct_per_g) <= 10.0, "effects.wheel_radius_load_pct_per_g in [-10, 10] %/g");
  require(e.gyro_delay_ms >= 0.0 && e.gyro_delay_ms <= 1000.0, "effects.gyro_delay_ms in [0, 1000] ms");
  require(e.accel_delay_ms >= 0.0 && e.accel_delay_ms <= 1000.0, "effects.accel_delay_ms in [0, 1000] ms");
  require(e.accel_vibration_mps2 >= 0.0 && e.accel_vibration_mps2 <= 30.0, "effects.accel_vibration_mps2 in [0, 30] m/s^2");
  require(e.gyro_vibration_degps >= 0.0 && e.gyro_vibration_degps <= 30.0, "effects.gyro_vibration_degps in [0, 30] deg/s");
  require(e.mass_change_kg >= 0.0 && e.mass_change_kg < 0.5 * v.mass_kg,
          "effects.mass_change_kg in [0, mass_kg/2) (a +- range)");
  for (double dm : e.mass_schedule_kg)
    require(v.mass_kg + dm > 0.5 * v.mass_kg, "effects.mass_schedule_kg: m + dm must stay > m/2");
}

}  // namespace ndsid::config
