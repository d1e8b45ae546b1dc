// `ndsid init`'s outputs: the commented vehicle YAML and the console summary.
#include <spdlog/fmt/fmt.h>

#include <cmath>
#include <sstream>

#include "vehicle_init.h"

namespace ndsid::desk {

using config::Role;

namespace {

const char* RoleTitle(Role r) {
  switch (r) {
    case Role::kSteeringWheelAngle: return "steering-wheel angle";
    case Role::kSpeed: return "vehicle speed";
    case Role::kLateralAcceleration: return "lateral acceleration";
    case Role::kYawRate: return "yaw rate";
    case Role::kLongitudinalAcceleration: return "longitudinal acceleration";
    case Role::kWheelSpeed: return "wheel speeds' mean (plausibility of vehicle_speed)";
    case Role::kRearWheelSpeedDifference: return "rear wheel speeds, right minus left (a yaw-rate reference)";
    default: return "";
  }
}

const char* Sureness(double c) { return c >= 0.9 ? "high" : c >= 0.7 ? "medium" : "low"; }

std::string Quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string Number(double x) { return fmt::format("{:g}", x); }

// The vehicle section: the data-sheet values given; a value not given is written as a commented-out
// key that says why the file does not load without it (no placeholder that would load).
void WriteVehicle(std::ostringstream& y, const InitYamlInputs& in) {
  const VehicleSheet& v = in.vehicle;
  y << "vehicle:\n"
    << "  name: " << Quoted(in.vehicle_name) << "   # keys the learned state (state_dir below follows it)\n";
  if (std::isfinite(v.wheelbase_m)) {
    y << "  wheelbase_m: " << Number(v.wheelbase_m) << "   # l from --wheelbase [m]; EG scales with it\n";
  } else {
    y << "  # NOT STATED: this car's wheelbase l [m]. EG scales with it (l 2 % off gives EG 2 % off), so this\n"
      << "  # file does not load until it is set: uncomment the key with l from the data sheet (or run init\n"
      << "  # again with --wheelbase).\n"
      << "  # wheelbase_m:\n";
  }
  if (std::isfinite(v.mass_kg)) {
    y << "  mass_kg: " << Number(v.mass_kg) << "   # m [kg] (curb + driver) from the command line; the parameter box scales with it\n";
  } else {
    y << "  # NOT STATED: this car's mass m [kg] (curb + driver). It does not move EG, but Jz and the cornering\n"
      << "  # stiffnesses are reported in its units and the parameter box is built from it, so this file does\n"
      << "  # not load until it is set: uncomment the key with m from the data sheet (or run init with --mass).\n"
      << "  # mass_kg:\n";
  }
  if (v.front_axle_load_kg > 0 && v.rear_axle_load_kg > 0) {
    y << "  front_axle_load_kg: " << Number(v.front_axle_load_kg) << "   # data sheet: centre the box's lv\n"
      << "  rear_axle_load_kg: " << Number(v.rear_axle_load_kg) << "\n";
  }
  if (v.track_front_m > 0) y << "  track_front_m: " << Number(v.track_front_m) << "   # [m]\n";
  if (v.track_rear_m > 0) y << "  track_rear_m: " << Number(v.track_rear_m) << "   # [m]\n";
}

}  // namespace

std::string VehicleConfigYaml(const InitResult& result, const InitYamlInputs& in) {
  std::ostringstream y;
  y << "# Vehicle configuration proposed by `ndsid init` from the DBC and a recorded log\n"
    << "# (" << in.command_line << ").\n"
    << "# The roles below were confirmed from the data by physics (a_y = v r, r = v d_sw / (is l (1 + v^2/v_ch^2)));\n"
    << "# the evidence and confidence are in the comment above each. Check every line marked CHECK, then\n"
    << "# replay: `ndsid replay --config <this file>`. Every key: docs/configuration.md; how init decides: docs/new-car.md.\n";
  for (const auto& n : result.notes) y << "# " << n << "\n";
  y << "\n";
  WriteVehicle(y, in);
  if (result.road_wheel_angle)
    y << "  steering_angle_at: road_wheels   # the steering signal reads the road wheels (steer ratio about 1; docs/new-car.md)\n";
  y << "\nsource:\n"
    << "  type: log\n"
    << "  logs: [" << Quoted(in.log_path) << "]\n"
    << "  bus: " << Quoted(result.bus) << (result.bus.empty() ? "                   # all buses\n" : "              # the bus the roles were found on\n")
    << "\ndbc: " << Quoted(in.dbc_path) << "\n"
    << "\n# Signal roles: the unit on the bus and the sign that makes the value ISO 8855 (x forward, y left,\n"
    << "# z up; steering, yaw rate, a_y positive to the left). Timeouts: 10 measured message periods, >= 0.1 s.\n"
    << "signals:\n";
  for (const auto& p : result.roles) {
    const std::string key = config::RoleKey(p.role);
    if (!p.found) {
      y << "  # " << key << ": not found: " << p.reason << "\n";
      continue;
    }
    y << "  # " << RoleTitle(p.role) << ": confidence " << fmt::format("{:.0f} %", 100 * p.confidence) << " ("
      << Sureness(p.confidence) << ")" << (p.confidence < 0.7 ? " CHECK" : "") << "; message period "
      << fmt::format("{:.0f} ms", 1000 * p.period_s) << "\n";
    for (const auto& e : p.evidence) y << "  #   " << e << "\n";
    // The rear difference needs the rear track: without it, the role is written commented out.
    const bool needs_track = p.role == Role::kRearWheelSpeedDifference && !(in.vehicle.track_rear_m > 0);
    if (needs_track) y << "  #   needs vehicle.track_rear_m (init --track-rear, from the data sheet): uncomment with it\n";
    y << (needs_track ? "  # " : "  ") << key << ": {";
    if (p.multi_signal) y << "expr: " << Quoted(p.expression);
    else y << "message: " << p.message << ", signal: " << p.signal;
    y << ", unit: " << p.unit;
    if (p.role != Role::kSpeed || p.sign != 1) y << ", sign: " << p.sign;
    y << ", timeout_s: " << Number(p.timeout_s);
    if (p.lowpass_hz > 0) y << ", lowpass_hz: " << Number(p.lowpass_hz);
    y << "}\n";
  }
  y << "\ngate:\n"
    << "  min_drive_km: 2.0           # drives shorter than this are not used (the study's rule) [km]\n";
  // With a yaw rate on the bus: both outputs fitted, the road's bank tracked through the yaw
  // rate, and the gyro's offset (every real gyro has one; the stops measure it) in the model.
  const RoleProposal* yaw = result.Find(config::Role::kYawRate);
  if (yaw && yaw->found) {
    y << "\nmodel:\n"
      << "  effects: [road_bank, gyro_offset]  # the bank tracked through the yaw rate; the gyro's offset\n"
      << "                                     # (docs/two-outputs.md; `ndsid diagnose` proposes more)\n"
      << "\nidentification:\n"
      << "  outputs: [a_y, yaw_rate]    # the yaw rate fitted as a second output (docs/two-outputs.md)\n";
  }
  y
    << "\n# identification: the parameter box is this car's physical box, from vehicle.wheelbase_m and\n"
    << "# vehicle.mass_kg (and the axle loads where given; docs/configuration.md, \"The parameter box\").\n"
    << "\nstate_dir: " << Quoted("out/state/" + (in.state_name.empty() ? in.vehicle_name : in.state_name))
    << "   # this car's learned state (systemd: /var/lib/ndsid/<name>)\n"
    << "report_dir: out/report        # reports of the ndsid commands (relative to this file)\n";
  return y.str();
}

std::string InitSummary(const InitResult& result, const VehicleSheet& vehicle) {
  std::ostringstream o;
  o << fmt::format("read {} frames, {:.1f} s of log, {:.1f} s above 5 m/s{}\n", result.frames, result.log_duration_s,
                   result.moving_s, result.bus.empty() ? "" : ", roles on bus " + result.bus);
  if (result.truncated) o << "  (stopped at the frame limit: the rest of the log was not read; --max-frames)\n";
  for (const auto& p : result.roles) {
    const bool mandatory = config::RoleIsRequired(p.role);
    if (!p.found) {
      o << fmt::format("{:<26} NOT FOUND{}: {}\n", config::RoleKey(p.role), mandatory ? " (required)" : "", p.reason);
      continue;
    }
    o << fmt::format("{:<26} {}  unit {}  sign {:+d}  timeout {:g} s{}  confidence {:.0f} % ({})\n", config::RoleKey(p.role),
                     p.expression, p.unit, p.sign, p.timeout_s,
                     p.lowpass_hz > 0 ? fmt::format("  lowpass {:g} Hz", p.lowpass_hz) : "", 100 * p.confidence,
                     Sureness(p.confidence));
    for (const auto& e : p.evidence) o << "    " << e << "\n";
  }
  for (const auto& n : result.notes) o << "note: " << n << "\n";
  o << (result.MandatoryFound() ? "required roles (steering, speed, a_y): found\n"
                                : "required roles (steering, speed, a_y): NOT all found; the config has them commented out\n");
  if (!std::isfinite(vehicle.wheelbase_m)) {
    o << "WARNING: vehicle.wheelbase_m is not stated: EG scales with the wheelbase, so the written file does not "
         "load until it is set from the data sheet (or run init again with --wheelbase)\n";
  }
  if (!std::isfinite(vehicle.mass_kg)) {
    o << "WARNING: vehicle.mass_kg is not stated: the parameter box and the units of Jz and the stiffnesses need it, "
         "so the written file does not load until it is set (or run init again with --mass)\n";
  }
  return o.str();
}

}  // namespace ndsid::desk
