// The configuration's sections other than signals and model (config_sections.h).
#include "config_sections.h"

#include "ndsid/config/parameter_box.h"

#include <algorithm>
#include <cmath>
#include <array>
#include <cstdio>
#include <filesystem>

namespace ndsid::config {
namespace {

std::string Shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// identification.parameters: the base parameters' box, initial values and which are fixed. A
// parameter without its own entry takes the physical box of this car (parameter_box.h: from
// wheelbase, mass and, where given, axle loads), not another car's.
void ReadParams(const YamlReader& r, const VehicleConfig& vehicle, IdentificationConfig& id) {
  static const char* const kKeys[6] = {"m", "Jz", "cv", "ch", "lv", "is"};
  const std::array<ParameterSpec, 6> physical = PhysicalParameterBox(vehicle);
  const YamlReader params = r.Has("parameters") ? r.Child("parameters") : YamlReader(YAML::Node(), r.file(), "identification.parameters");
  for (int i = 0; i < 6; ++i) {
    ParameterSpec& p = id.params[i];
    p = physical[i];
    if (params.Has(kKeys[i])) {
      const YamlReader pr = params.Child(kKeys[i]);
      p.lower = Ranged(pr, "min", p.lower, 0, kMaxParameterBound);
      p.upper = Ranged(pr, "max", p.upper, 0, kMaxParameterBound);
      const bool own_box = pr.Has("min") || pr.Has("max");
      p.initial = Ranged(pr, "initial", own_box ? 0.0 : p.initial, 0, kMaxParameterBound);
      p.fixed = pr.Bool("fixed", p.fixed);
      pr.Finish();
      if (!(p.lower > 0 && p.upper > p.lower)) params.Fail(kKeys[i], "needs 0 < min < max");
    } else {
      params.Raw(kKeys[i]);
    }
    if (p.initial == 0.0) p.initial = (i == 0 && vehicle.mass_kg > 0) ? vehicle.mass_kg : 0.5 * (p.lower + p.upper);
    if (i == 0 && p.fixed && vehicle.mass_kg > 0) p.initial = vehicle.mass_kg;
    if (p.initial < p.lower || p.initial > p.upper) {
      if (i == 0 && p.fixed) {
        p.lower = std::min(p.lower, p.initial);
        p.upper = std::max(p.upper, p.initial);
      } else {
        params.Fail(kKeys[i], "initial value outside [min, max]");
      }
    }
  }
  params.Finish();
}

}  // namespace

std::string Resolve(const std::string& base_dir, const std::string& p) {
  if (p.empty() || std::filesystem::path(p).is_absolute()) return p;
  return (std::filesystem::path(base_dir) / p).lexically_normal().string();
}

void CheckRange(const YamlReader& r, const std::string& key, double v, double lo, double hi) {
  if (!(v >= lo && v <= hi)) {
    r.Fail(key, "value " + Shortest(v) + " out of range [" + Shortest(lo) + ", " + Shortest(hi) + "]");
  }
}

double Ranged(const YamlReader& r, const std::string& key, double fallback, double lo, double hi) {
  const double v = r.Number(key, fallback);
  CheckRange(r, key, v, lo, hi);
  return v;
}

void ReadVehicle(const YamlReader& v, VehicleConfig& vehicle) {
  vehicle.name = v.String("name");
  if (vehicle.name.empty()) v.Fail("name", "must not be empty");
  // Both from the data sheet, never a default: EG scales with l, and the box and the units of Jz and
  // the stiffnesses with m (ndsid init writes the key commented out when it was not given).
  if (!v.Has("wheelbase_m")) v.Fail("wheelbase_m", "not stated; EG scales with it: set l [m] from the data sheet");
  vehicle.wheelbase_m = v.Number("wheelbase_m");
  CheckRange(v, "wheelbase_m", vehicle.wheelbase_m, 1.0, 8.0);
  if (!v.Has("mass_kg")) {
    v.Fail("mass_kg", "not stated; the parameter box and the units of Jz and the stiffnesses need it: set m [kg] from "
                      "the data sheet");
  }
  vehicle.mass_kg = v.Number("mass_kg");
  CheckRange(v, "mass_kg", vehicle.mass_kg, 200.0, 60000.0);
  // Optional data-sheet values (0: not given): the axle loads narrow the box's lv.
  vehicle.front_axle_load_kg = Ranged(v, "front_axle_load_kg", 0.0, 0, 60000.0);
  vehicle.rear_axle_load_kg = Ranged(v, "rear_axle_load_kg", 0.0, 0, 60000.0);
  if ((vehicle.front_axle_load_kg > 0) != (vehicle.rear_axle_load_kg > 0)) {
    v.Fail(vehicle.front_axle_load_kg > 0 ? "rear_axle_load_kg" : "front_axle_load_kg",
           "give both axle loads or neither");
  }
  if (vehicle.front_axle_load_kg > 0) {
    const double sum = vehicle.front_axle_load_kg + vehicle.rear_axle_load_kg;
    if (std::abs(sum - vehicle.mass_kg) > 0.15 * vehicle.mass_kg) {
      v.Fail("rear_axle_load_kg", "the axle loads add up to " + Shortest(sum) + " kg, more than 15 % from mass_kg " +
                                      Shortest(vehicle.mass_kg));
    }
  }
  vehicle.track_front_m = Ranged(v, "track_front_m", 0.0, 0, 5.0);
  vehicle.track_rear_m = Ranged(v, "track_rear_m", 0.0, 0, 5.0);
  const std::string at = v.String("steering_angle_at", "steering_wheel");
  if (at != "steering_wheel" && at != "road_wheels") v.Fail("steering_angle_at", "must be 'steering_wheel' or 'road_wheels', got '" + at + "'");
  vehicle.road_wheel_angle = at == "road_wheels";
  v.Finish();
}

void ReadSource(const YamlReader& s, const std::string& base_dir, SourceConfig& source) {
  const std::string type = s.String("type");
  if (type == "log") {
    source.type = SourceConfig::Type::kLog;
    for (const auto& l : s.Strings("logs", {})) source.logs.push_back(Resolve(base_dir, l));
    if (source.logs.empty()) s.Fail("logs", "a log source needs at least one file");
  } else if (type == "socketcan") {
    source.type = SourceConfig::Type::kSocketCan;
    source.interface = s.String("interface");
    s.Strings("logs", {});
  } else {
    s.Fail("type", "must be 'log' or 'socketcan', got '" + type + "'");
  }
  if (source.type == SourceConfig::Type::kLog) s.String("interface", "");
  source.bus = s.String("bus", "");
  source.realtime = s.Bool("realtime", false);
  s.Finish();
}

void ReadSync(const YamlReader& s, SyncConfig& sync) {
  sync.rate_hz = Ranged(s, "rate_hz", sync.rate_hz, 10, 1000);
  sync.latency_s = Ranged(s, "latency_s", sync.latency_s, 1e-3, 10);
  sync.max_fill_gap_s = Ranged(s, "max_fill_gap_s", sync.max_fill_gap_s, 1e-3, 3600);
  s.Finish();
}

void ReadGate(const YamlReader& g, GateConfig& gc) {
  gc.min_speed_mps = Ranged(g, "min_speed_mps", gc.min_speed_mps, 0.1, 100);
  gc.standstill_speed_mps = Ranged(g, "standstill_speed_mps", gc.standstill_speed_mps, 1e-3, 10);
  gc.standstill_min_s = Ranged(g, "standstill_min_s", gc.standstill_min_s, 1e-3, 3600);
  gc.max_abs_lat_accel_mps2 = Ranged(g, "max_abs_lat_accel_mps2", gc.max_abs_lat_accel_mps2, 0.1, 30);
  gc.drive_gap_s = Ranged(g, "drive_gap_s", gc.drive_gap_s, 0.1, 86400);
  gc.min_drive_km = Ranged(g, "min_drive_km", gc.min_drive_km, 0, 1000);
  gc.min_segment_s = Ranged(g, "min_segment_s", gc.min_segment_s, 0.01, 3600);
  gc.quasi_steady_max_steer_rate_radps =
      Ranged(g, "quasi_steady_max_steer_rate_radps", gc.quasi_steady_max_steer_rate_radps, 1e-6, 100);
  gc.quasi_steady_max_yaw_accel_radps2 =
      Ranged(g, "quasi_steady_max_yaw_accel_radps2", gc.quasi_steady_max_yaw_accel_radps2, 1e-6, 100);
  g.Finish();
}

void ReadIdentification(const YamlReader& id, const std::string& base_dir, const VehicleConfig& vehicle, bool has_yaw_rate,
                        IdentificationConfig& ic) {
  ReadParams(id, vehicle, ic);
  ic.prior_from = Resolve(base_dir, id.String("prior_from", ""));
  ic.prior_group = id.String("prior_group", "");
  if (NamesFleetTable(ic.prior_from) && ic.prior_group.empty()) id.Fail("prior_group", "names the group whose prior prior_from's fleet table holds");
  if (!ic.prior_group.empty() && ic.prior_from.empty()) id.Fail("prior_group", "needs prior_from (a fleet table)");
  ic.rate_hz = Ranged(id, "rate_hz", ic.rate_hz, 10, 200);
  ic.burn_in_s = Ranged(id, "burn_in_s", ic.burn_in_s, 1e-3, 600);
  ic.chunk_s = Ranged(id, "chunk_s", ic.chunk_s, 0.1, 3600);
  if (ic.chunk_s <= 2 * ic.burn_in_s) id.Fail("chunk_s", "must exceed twice burn_in_s");
  ic.window_h = Ranged(id, "window_h", ic.window_h, 1e-3, 1e5);
  ic.period_s = Ranged(id, "period_s", ic.period_s, 1, 1e7);
  ic.validation_fraction = Ranged(id, "validation_fraction", ic.validation_fraction, 0.0, 0.9);
  ic.max_iterations = id.Integer("max_iterations", ic.max_iterations);
  CheckRange(id, "max_iterations", ic.max_iterations, 1, 100000);
  ic.threads = id.Integer("threads", ic.threads);
  CheckRange(id, "threads", ic.threads, 1, 256);
  ic.incremental = id.Bool("incremental", ic.incremental);
  ic.relinearize_sigma = Ranged(id, "relinearize_sigma", ic.relinearize_sigma, 0.01, 100);
  ic.full_refit_every = id.Integer("full_refit_every", ic.full_refit_every);
  CheckRange(id, "full_refit_every", ic.full_refit_every, 0, 1000000);
  if (id.Has("outputs")) {
    const std::vector<std::string> outputs = id.Strings("outputs", {"a_y"});
    if (outputs == std::vector<std::string>{"a_y"}) {
      ic.yaw_rate_output = false;
    } else if (outputs == std::vector<std::string>{"a_y", "yaw_rate"} ||
               outputs == std::vector<std::string>{"yaw_rate", "a_y"}) {
      ic.yaw_rate_output = true;
    } else {
      id.Fail("outputs", "must be [a_y] or [a_y, yaw_rate] (a_y is always fitted)");
    }
  } else {
    // Not stated: both outputs when the bus has a yaw rate (docs/two-outputs.md), else a_y.
    ic.yaw_rate_output = has_yaw_rate;
  }
  id.Finish();
}

void ReadAdequacy(const YamlReader& a, AdequacyConfig& adequacy) {
  adequacy.tolerance = Ranged(a, "tolerance", adequacy.tolerance, 1e-6, 1);
  adequacy.hold_h = Ranged(a, "hold_h", adequacy.hold_h, 1e-3, 1e5);
  adequacy.change_window_h = Ranged(a, "change_window_h", adequacy.change_window_h, 1e-3, 1e5);
  adequacy.kl_threshold = Ranged(a, "kl_threshold", adequacy.kl_threshold, 1e-9, 100);
  a.Finish();
}

void ReadPlausibility(const YamlReader& p, PlausibilityConfig& q) {
  // q arrives with the vehicle's defaults (ParseConfigText: the steer-ratio range of a road-wheel angle).
  q.kinematic_gain_min = Ranged(p, "kinematic_gain_min", q.kinematic_gain_min, 0.01, 1);
  q.kinematic_gain_max = Ranged(p, "kinematic_gain_max", q.kinematic_gain_max, 1, 100);
  q.kinematic_correlation_min = Ranged(p, "kinematic_correlation_min", q.kinematic_correlation_min, 0, 1);
  q.steer_yaw_correlation_min = Ranged(p, "steer_yaw_correlation_min", q.steer_yaw_correlation_min, 0, 1);
  q.steer_ratio_min = Ranged(p, "steer_ratio_min", q.steer_ratio_min, 0.1, 1000);
  q.steer_ratio_max = Ranged(p, "steer_ratio_max", q.steer_ratio_max, 0.1, 1000);
  if (q.steer_ratio_max <= q.steer_ratio_min) p.Fail("steer_ratio_max", "must be above steer_ratio_min");
  q.eg_min_deg_per_g = Ranged(p, "eg_min_deg_per_g", q.eg_min_deg_per_g, -100, 100);
  q.eg_max_deg_per_g = Ranged(p, "eg_max_deg_per_g", q.eg_max_deg_per_g, -100, 100);
  if (q.eg_max_deg_per_g <= q.eg_min_deg_per_g) p.Fail("eg_max_deg_per_g", "must be above eg_min_deg_per_g");
  q.eg_rel_se_max = Ranged(p, "eg_rel_se_max", q.eg_rel_se_max, 1e-3, 100);
  q.eg_se_floor_deg_per_g = Ranged(p, "eg_se_floor_deg_per_g", q.eg_se_floor_deg_per_g, 0, 100);
  q.min_informative_s = Ranged(p, "min_informative_s", q.min_informative_s, 0, 1e6);
  q.wheel_speed_ratio_min = Ranged(p, "wheel_speed_ratio_min", q.wheel_speed_ratio_min, 0.01, 1);
  q.wheel_speed_ratio_max = Ranged(p, "wheel_speed_ratio_max", q.wheel_speed_ratio_max, 1, 100);
  q.wheel_speed_correlation_min = Ranged(p, "wheel_speed_correlation_min", q.wheel_speed_correlation_min, 0, 1);
  // The checks of the fit (adequacy/fit_checks.h).
  q.rmse_floor_ratio_max = Ranged(p, "rmse_floor_ratio_max", q.rmse_floor_ratio_max, 1, 1000);
  q.rmse_spread_ratio_max = Ranged(p, "rmse_spread_ratio_max", q.rmse_spread_ratio_max, 0.01, 10);
  q.rmse_negligible_spread_ratio = Ranged(p, "rmse_negligible_spread_ratio", q.rmse_negligible_spread_ratio, 0, 1);
  if (q.rmse_negligible_spread_ratio >= q.rmse_spread_ratio_max)
    p.Fail("rmse_negligible_spread_ratio", "must be below rmse_spread_ratio_max");
  q.bound_shift_sigma_max = Ranged(p, "bound_shift_sigma_max", q.bound_shift_sigma_max, 0.01, 1000);
  q.steady_state_z_max = Ranged(p, "steady_state_z_max", q.steady_state_z_max, 0.1, 1000);
  q.steady_state_rel_bias = Ranged(p, "steady_state_rel_bias", q.steady_state_rel_bias, 0, 10);
  q.halves_z_max = Ranged(p, "halves_z_max", q.halves_z_max, 0.1, 1000);
  q.model_choice_spread_rel_max = Ranged(p, "model_choice_spread_rel_max", q.model_choice_spread_rel_max, 0, 100);
  p.Finish();
}

void ReadLcm(const YamlReader& l, LcmConfig& lcm) {
  lcm.url = l.String("url", lcm.url);
  lcm.estimate_channel = l.String("estimate_channel", lcm.estimate_channel);
  lcm.status_channel = l.String("status_channel", lcm.status_channel);
  lcm.monitor_channel = l.String("monitor_channel", lcm.monitor_channel);
  lcm.status_rate_hz = Ranged(l, "status_rate_hz", lcm.status_rate_hz, 0.01, 1000);
  lcm.monitor_rate_hz = Ranged(l, "monitor_rate_hz", lcm.monitor_rate_hz, 0.01, 1000);
  l.Finish();
}

void ReadTopLevel(const YamlReader& top, const std::string& base_dir, Config& c) {
  c.state_dir = Resolve(base_dir, top.String("state_dir", c.state_dir));
  if (top.Has("state_unreadable")) {
    const std::string v = top.String("state_unreadable");
    if (v == "run_without_persisting") {
      c.run_without_persisting_if_unreadable = true;
    } else if (v != "stop") {
      top.Fail("state_unreadable", "must be 'stop' or 'run_without_persisting', not '" + v + "'");
    }
  }
  // Like every path in the file, relative to the file's folder; absent, the default
  // (out/report) stays relative to the working directory of the desk command.
  if (top.Has("report_dir")) c.report_dir = Resolve(base_dir, top.String("report_dir"));
  c.log_level = top.String("log_level", c.log_level);
  static const char* kLevels[] = {"trace", "debug", "info", "warn", "error", "critical", "off"};
  if (std::none_of(std::begin(kLevels), std::end(kLevels), [&](const char* l) { return c.log_level == l; })) {
    top.Fail("log_level", "must be one of trace, debug, info, warn, error, critical, off");
  }
}

}  // namespace ndsid::config
