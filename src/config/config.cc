#include "ndsid/config/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "ndsid/common/atomic_file.h"
#include "ndsid/common/closest_match.h"
#include "ndsid/dbc/database.h"
#include "yaml_reader.h"

namespace ndsid::config {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr size_t kMaxConfigBytes = 16 << 20;  // a vehicle YAML is a few kB

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
};

std::string Resolve(const std::string& base_dir, const std::string& p) {
  if (p.empty() || std::filesystem::path(p).is_absolute()) return p;
  return (std::filesystem::path(base_dir) / p).lexically_normal().string();
}

std::string Shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

void CheckRange(const YamlReader& r, const std::string& key, double v, double lo, double hi) {
  if (!(v >= lo && v <= hi)) {
    r.Fail(key, "value " + Shortest(v) + " out of range [" + Shortest(lo) + ", " + Shortest(hi) + "]");
  }
}

// Every number of the configuration is range-checked where it is read (docs/configuration.md
// lists the ranges): an absurd value (status_rate_hz: 1e-300, sync.latency_s: 1e15) would
// otherwise overflow a conversion to a period or a count later.
double Ranged(const YamlReader& r, const std::string& key, double fallback, double lo, double hi) {
  const double v = r.Number(key, fallback);
  CheckRange(r, key, v, lo, hi);
  return v;
}

constexpr double kMaxTimeoutS = 60;             // signal staleness
constexpr double kMaxPhysical = 1e12;           // formula parameter bounds, prior values
constexpr double kMaxParameterBound = 1e9;      // m, Jz, cv, ch, lv, is box

SignalRef ReadRef(const YamlReader& r) { return {r.String("message"), r.String("signal")}; }

// A role expression: its MESSAGE.SIGNAL names become the inputs, in order of appearance.
void ReadRoleExpression(const YamlReader& r, RoleSignal& s) {
  s.expr = r.String("expr");
  if (r.Has("message") || r.Has("signal")) r.Fail("expr", "give either expr or message + signal, not both");
  std::vector<std::string> names;
  const std::string& t = s.expr;
  for (size_t i = 0; i < t.size();) {
    const auto word = [&](size_t k) { return std::isalnum(static_cast<unsigned char>(t[k])) || t[k] == '_'; };
    if (!(std::isalpha(static_cast<unsigned char>(t[i])) || t[i] == '_') || (i > 0 && (word(i - 1) || t[i - 1] == '.'))) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j < t.size() && (word(j) || (t[j] == '.' && j + 1 < t.size() && (std::isalpha(static_cast<unsigned char>(t[j + 1])) || t[j + 1] == '_'))))
      ++j;
    const std::string name = t.substr(i, j - i);
    const size_t dot = name.find('.');
    if (dot != std::string::npos && std::find(names.begin(), names.end(), name) == names.end()) {
      if (name.find('.', dot + 1) != std::string::npos) r.Fail("expr", "'" + name + "': a signal is MESSAGE.SIGNAL (one '.')");
      names.push_back(name);
      s.inputs.push_back({name.substr(0, dot), name.substr(dot + 1)});
    }
    i = j;
  }
  if (s.inputs.empty()) r.Fail("expr", "'" + s.expr + "' names no signal (write MESSAGE.SIGNAL)");
  try {
    s.expression = std::make_shared<const Expression>(Expression::Parse(s.expr, names));
  } catch (const ConfigError& e) {
    r.Fail("expr", e.what());
  }
  s.ref = s.inputs.front();
}

RoleSignal ReadRole(const YamlReader& parent, Role role) {
  const YamlReader r = parent.Child(RoleKey(role));
  RoleSignal s;
  if (r.Has("expr")) {
    ReadRoleExpression(r, s);
  } else {
    s.ref = ReadRef(r);
  }
  s.line = parent.Line(RoleKey(role));
  if (RoleIsFlag(role)) {
    s.active_values = r.Numbers("active_values", {1.0});
    s.timeout_s = Ranged(r, "timeout_s", 0.5, 1e-3, kMaxTimeoutS);
  } else {
    s.unit = r.String("unit");
    const double sign = r.Number("sign", 1.0);
    if (sign != 1.0 && sign != -1.0) r.Fail("sign", "must be 1 or -1");
    try {
      s.scale_to_si = sign * UnitToSi(role, s.unit);
    } catch (const ConfigError& e) {
      r.Fail("unit", e.what());
    }
    s.timeout_s = Ranged(r, "timeout_s", 0.1, 1e-3, kMaxTimeoutS);
    s.latency_s = r.Number("latency_s", 0.0);
    CheckRange(r, "latency_s", s.latency_s, -0.2, 0.5);
    if (role == Role::kLateralAcceleration && s.latency_s != 0.0) {
      r.Fail("latency_s", "the lateral acceleration is the time reference: give the other roles' latencies relative to it");
    }
  }
  r.Finish();
  return s;
}

void ReadParams(const YamlReader& r, const VehicleConfig& vehicle, IdentificationConfig& id) {
  // Defaults: the study's box for a C-Max-class car (physics.md §1), m fixed to the data sheet.
  struct Default {
    const char* key;
    double lo, hi;
  };
  const Default defaults[6] = {{"m", 1800, 2000},  {"Jz", 2200, 3200},   {"cv", 65000, 90000},
                               {"ch", 110000, 135000}, {"lv", 1.0, 1.3}, {"is", 14.2, 15.3}};
  const YamlReader params = r.Has("parameters") ? r.Child("parameters") : YamlReader(YAML::Node(), r.file(), "identification.parameters");
  for (int i = 0; i < 6; ++i) {
    ParameterSpec& p = id.params[i];
    p.lower = defaults[i].lo;
    p.upper = defaults[i].hi;
    p.fixed = (i == 0);
    if (params.Has(defaults[i].key)) {
      const YamlReader pr = params.Child(defaults[i].key);
      p.lower = Ranged(pr, "min", p.lower, 0, kMaxParameterBound);
      p.upper = Ranged(pr, "max", p.upper, 0, kMaxParameterBound);
      p.initial = Ranged(pr, "initial", 0.0, 0, kMaxParameterBound);
      p.fixed = pr.Bool("fixed", p.fixed);
      pr.Finish();
      if (!(p.lower > 0 && p.upper > p.lower)) params.Fail(defaults[i].key, "needs 0 < min < max");
    } else {
      params.Raw(defaults[i].key);
    }
    if (p.initial == 0.0) p.initial = (i == 0 && vehicle.mass_kg > 0) ? vehicle.mass_kg : 0.5 * (p.lower + p.upper);
    if (i == 0 && p.fixed && vehicle.mass_kg > 0) p.initial = vehicle.mass_kg;
    if (p.initial < p.lower || p.initial > p.upper) {
      if (i == 0 && p.fixed) {
        p.lower = std::min(p.lower, p.initial);
        p.upper = std::max(p.upper, p.initial);
      } else {
        params.Fail(defaults[i].key, "initial value outside [min, max]");
      }
    }
  }
  params.Finish();
}

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
    case Role::kWheelSpeed: units = {{"km/h", 1.0 / 3.6}, {"kph", 1.0 / 3.6}, {"m/s", 1.0}, {"mph", 0.44704}}; break;
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

Config ParseConfigText(const std::string& yaml_text, const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(FormatLocation(path, e.mark.line + 1, e.mark.column + 1, "YAML syntax: " + e.msg));
  }
  if (!root || !root.IsMap()) throw ConfigError(FormatLocation(path, 1, 0, "expected a YAML mapping at the top"));
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  const YamlReader top(root, path, "");
  Config c;
  c.path = path;

  {
    const YamlReader v = top.Child("vehicle");
    c.vehicle.name = v.String("name");
    if (c.vehicle.name.empty()) v.Fail("name", "must not be empty");
    c.vehicle.wheelbase_m = v.Number("wheelbase_m");
    CheckRange(v, "wheelbase_m", c.vehicle.wheelbase_m, 1.0, 8.0);
    c.vehicle.mass_kg = v.Number("mass_kg");
    CheckRange(v, "mass_kg", c.vehicle.mass_kg, 200.0, 60000.0);
    v.Finish();
  }
  {
    const YamlReader s = top.Child("source");
    const std::string type = s.String("type");
    if (type == "log") {
      c.source.type = SourceConfig::Type::kLog;
      for (const auto& l : s.Strings("logs", {})) c.source.logs.push_back(Resolve(base_dir, l));
      if (c.source.logs.empty()) s.Fail("logs", "a log source needs at least one file");
    } else if (type == "socketcan") {
      c.source.type = SourceConfig::Type::kSocketCan;
      c.source.interface = s.String("interface");
      s.Strings("logs", {});
    } else {
      s.Fail("type", "must be 'log' or 'socketcan', got '" + type + "'");
    }
    if (c.source.type == SourceConfig::Type::kLog) s.String("interface", "");
    c.source.bus = s.String("bus", "");
    c.source.realtime = s.Bool("realtime", false);
    s.Finish();
  }
  c.dbc = Resolve(base_dir, top.String("dbc"));
  {
    const YamlReader sig = top.Child("signals");
    for (int i = 0; i < kNumRoles; ++i) {
      const Role role = static_cast<Role>(i);
      if (sig.Has(RoleKey(role))) {
        c.roles[i] = ReadRole(sig, role);
      } else if (RoleIsRequired(role)) {
        sig.Fail(RoleKey(role), "missing required role");
      } else {
        sig.Raw(RoleKey(role));
      }
    }
    const auto validity = sig.Raw("validity");
    if (validity) {
      if (!validity->IsSequence()) sig.FailAt(*validity, "validity", "expected a list");
      int idx = 0;
      for (const auto& item : *validity) {
        const YamlReader vr(item, path, "signals.validity[" + std::to_string(idx++) + "]");
        ValiditySignal v;
        v.ref = ReadRef(vr);
        v.valid_values = vr.Numbers("valid_values", {1.0});
        v.timeout_s = Ranged(vr, "timeout_s", 0.2, 1e-3, kMaxTimeoutS);
        v.line = item.Mark().line + 1;
        vr.Finish();
        c.validity.push_back(v);
      }
    }
    sig.Finish();
  }
  if (top.Has("sync")) {
    const YamlReader s = top.Child("sync");
    c.sync.rate_hz = Ranged(s, "rate_hz", c.sync.rate_hz, 10, 1000);
    c.sync.latency_s = Ranged(s, "latency_s", c.sync.latency_s, 1e-3, 10);
    c.sync.max_fill_gap_s = Ranged(s, "max_fill_gap_s", c.sync.max_fill_gap_s, 1e-3, 3600);
    s.Finish();
  }
  if (top.Has("gate")) {
    const YamlReader g = top.Child("gate");
    GateConfig& gc = c.gate;
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
  {
    const YamlReader id = top.Has("identification") ? top.Child("identification")
                                                   : YamlReader(YAML::Node(), path, "identification");
    IdentificationConfig& ic = c.identification;
    ReadParams(id, c.vehicle, ic);
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
      ic.yaw_rate_output = c.role(Role::kYawRate) != nullptr;
    }
    id.Finish();
  }
  if (top.Has("adequacy")) {
    const YamlReader a = top.Child("adequacy");
    c.adequacy.tolerance = Ranged(a, "tolerance", c.adequacy.tolerance, 1e-6, 1);
    c.adequacy.hold_h = Ranged(a, "hold_h", c.adequacy.hold_h, 1e-3, 1e5);
    c.adequacy.change_window_h = Ranged(a, "change_window_h", c.adequacy.change_window_h, 1e-3, 1e5);
    c.adequacy.kl_threshold = Ranged(a, "kl_threshold", c.adequacy.kl_threshold, 1e-9, 100);
    a.Finish();
  }
  if (top.Has("plausibility")) {
    const YamlReader p = top.Child("plausibility");
    PlausibilityConfig& q = c.plausibility;
    q.kinematic_gain_min = Ranged(p, "kinematic_gain_min", q.kinematic_gain_min, 0.01, 1);
    q.kinematic_gain_max = Ranged(p, "kinematic_gain_max", q.kinematic_gain_max, 1, 100);
    q.kinematic_correlation_min = Ranged(p, "kinematic_correlation_min", q.kinematic_correlation_min, 0, 1);
    q.steer_yaw_correlation_min = Ranged(p, "steer_yaw_correlation_min", q.steer_yaw_correlation_min, 0, 1);
    q.steer_ratio_min = Ranged(p, "steer_ratio_min", q.steer_ratio_min, 1, 1000);
    q.steer_ratio_max = Ranged(p, "steer_ratio_max", q.steer_ratio_max, 1, 1000);
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
    p.Finish();
  }
  if (top.Has("lcm")) {
    const YamlReader l = top.Child("lcm");
    c.lcm.url = l.String("url", c.lcm.url);
    c.lcm.estimate_channel = l.String("estimate_channel", c.lcm.estimate_channel);
    c.lcm.status_channel = l.String("status_channel", c.lcm.status_channel);
    c.lcm.monitor_channel = l.String("monitor_channel", c.lcm.monitor_channel);
    c.lcm.status_rate_hz = Ranged(l, "status_rate_hz", c.lcm.status_rate_hz, 0.01, 1000);
    c.lcm.monitor_rate_hz = Ranged(l, "monitor_rate_hz", c.lcm.monitor_rate_hz, 0.01, 1000);
    l.Finish();
  }
  if (top.Has("model")) {
    const YamlReader m = top.Child("model");
    c.model_effects = m.Strings("effects", {});
    if (m.Has("formulas")) {
      const YamlReader fs = m.Child("formulas");
      for (const auto& kv : fs.node()) {
        const std::string name = kv.first.as<std::string>();
        const YamlReader f = fs.Child(name);
        FormulaSpec spec;
        spec.name = name;
        spec.file = path;
        spec.line = fs.Line(name);
        for (const char* target : {"a_y_meas", "beta_dot", "r_dot"}) {
          if (f.Has(target)) {
            if (!spec.target.empty()) f.Fail(target, "a formula states one of a_y_meas, beta_dot, r_dot");
            spec.target = target;
            spec.expression = f.String(target);
          } else {
            f.Raw(target);
          }
        }
        if (spec.target.empty()) fs.Fail(name, "needs one of a_y_meas, beta_dot, r_dot");
        if (f.Has("parameters")) {
          const YamlReader ps = f.Child("parameters");
          for (const auto& pkv : ps.node()) {
            const std::string pname = pkv.first.as<std::string>();
            const YamlReader pr = ps.Child(pname);
            FormulaParam fp;
            fp.name = pname;
            fp.lower = pr.Number("min");
            CheckRange(pr, "min", fp.lower, -kMaxPhysical, kMaxPhysical);
            fp.upper = pr.Number("max");
            CheckRange(pr, "max", fp.upper, -kMaxPhysical, kMaxPhysical);
            fp.neutral = Ranged(pr, "neutral", 0.0, -kMaxPhysical, kMaxPhysical);
            fp.initial = Ranged(pr, "initial", fp.neutral, -kMaxPhysical, kMaxPhysical);
            fp.unit = pr.String("unit", "-");
            pr.Finish();
            if (!(fp.upper > fp.lower) || fp.initial < fp.lower || fp.initial > fp.upper) {
              ps.Fail(pname, "needs min < max and min <= initial <= max");
            }
            spec.params.push_back(fp);
          }
          ps.Finish();
        } else {
          f.Raw("parameters");
        }
        if (spec.params.empty()) fs.Fail(name, "a formula effect needs at least one parameter");
        f.Finish();
        c.model_formulas.push_back(spec);
      }
      fs.Finish();
    } else {
      m.Raw("formulas");
    }
    if (m.Has("priors")) {
      const YamlReader ps = m.Child("priors");
      for (const auto& kv : ps.node()) {
        const std::string name = kv.first.as<std::string>();
        const YamlReader pr = ps.Child(name);
        config::ParameterPrior prior;
        prior.name = name;
        prior.value = pr.Number("value");
        CheckRange(pr, "value", prior.value, -kMaxPhysical, kMaxPhysical);
        prior.sd = pr.Number("sd");
        CheckRange(pr, "sd", prior.sd, 0, kMaxPhysical);
        prior.location = path + ":" + std::to_string(ps.Line(name));
        pr.Finish();
        if (!(prior.sd > 0) || !std::isfinite(prior.value)) ps.Fail(name, "a prior needs a finite value and sd > 0");
        c.identification.priors.push_back(prior);
      }
      ps.Finish();
    } else {
      m.Raw("priors");
    }
    m.Finish();
  }
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
