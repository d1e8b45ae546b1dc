// `ndsid init`'s analysis: a new car's roles proposed from its DBC (names, units, comments)
// and confirmed from a recorded log by physics (docs/new-car.md):
//   a_y ~ v r                              which signals are v, r, a_y; a_y's sign relative to r;
//                                          the units of all three (one gain, 12 unit combinations)
//   r ~ v d_sw / (is l (1 + v^2/v_ch^2))   which signal is the steering angle, its sign relative
//                                          to r, deg vs rad from a plausible steer ratio 10..25
//   v ~ mean wheel speed                   speed unit consistency where wheel speeds are present
//   a_x ~ dv/dt                            longitudinal acceleration, its unit and sign
// The one absolute convention (ISO 8855: yaw rate positive to the left) comes from the DBC's
// comments when they say so, otherwise it is assumed and the summary says so.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "ndsid/can/frame_log.h"
#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"

namespace ndsid::desk {

struct InitOptions {
  std::string bus;                     // use only this bus ("" = each message on the bus it is seen most)
  double reference_wheelbase_m = 2.7;  // l for the steer-ratio plausibility (the car's is not known yet)
  uint64_t max_frames = 20'000'000;    // read at most this many frames (the decoded log is held in memory)
};

// One role as proposed: its signal(s), unit and sign, the evidence and how sure.
struct RoleProposal {
  config::Role role = config::Role::kSteeringWheelAngle;
  bool found = false;
  std::string message, signal;  // the (first) signal
  std::string expression;       // "MESSAGE.SIGNAL", or a role expression when the bus splits the quantity
  bool multi_signal = false;
  std::string unit;             // the config's unit string (deg, km/h, m/s^2, deg/s, ...)
  int sign = 1;                 // bus value * sign is ISO 8855
  double period_s = 0;          // measured median message period
  double timeout_s = 0.1;       // 10 periods, at least 0.1 s
  double confidence = 0;        // 0..1: the smallest of the choice's, the unit's and the sign's
  double lowpass_hz = 0;        // conditioning for a noisy sensor (signals.<role>.lowpass_hz; 0 = none)
  std::vector<std::string> evidence;  // one line each: correlation, fitted gain, ratio, posterior
  std::string reason;                 // why the role was not found
};

struct InitResult {
  std::vector<RoleProposal> roles;  // steering, speed, a_y, yaw rate, a_x (in config::Role order)
  std::string bus;                  // the bus of the found roles when the log has several
  std::vector<std::string> notes;   // conventions and assumptions
  double log_duration_s = 0;
  double moving_s = 0;              // time with speed above 5 m/s (once the speed is known)
  uint64_t frames = 0;
  bool truncated = false;           // stopped at InitOptions::max_frames
  bool road_wheel_angle = false;    // the steering signal reads the road wheels (steer ratio about 1)

  const RoleProposal* Find(config::Role role) const;
  bool MandatoryFound() const;  // steering, speed and a_y found
};

// Reads the whole log. Throws ConfigError when no frame decodes with the DBC.
InitResult ProposeVehicleConfig(const dbc::Database& db, can::FrameLog& log, const InitOptions& options = {});

// The data-sheet values given on the command line; a value not given is NaN (the axle loads and
// track widths: 0). Without the wheelbase and mass the YAML carries placeholders marked CHECK.
struct VehicleSheet {
  double wheelbase_m = NAN;         // l: EG scales with it
  double mass_kg = NAN;             // m: does not move EG; Jz and the stiffnesses are in its units
  double front_axle_load_kg = 0;    // both axle loads or neither: they centre the box's lv
  double rear_axle_load_kg = 0;
  double track_front_m = 0;         // optional track widths
  double track_rear_m = 0;
};

// Paths as they are to be written into the YAML (relative to the output file's folder).
struct InitYamlInputs {
  std::string vehicle_name;
  std::string log_path;
  std::string dbc_path;
  std::string command_line;
  std::string state_name;  // the learned state's folder under out/state/ ("" = vehicle_name)
  VehicleSheet vehicle;
};
// A commented vehicle YAML in the layout of config/example_vehicle.yaml; roles not found are
// written commented out with the reason.
std::string VehicleConfigYaml(const InitResult& result, const InitYamlInputs& inputs);

// What was decided per role, the evidence and how sure: the console summary; a warning line
// per data-sheet value left as a placeholder.
std::string InitSummary(const InitResult& result, const VehicleSheet& vehicle = {});

}  // namespace ndsid::desk
