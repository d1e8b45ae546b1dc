// The smallest valid vehicle YAML and a helper returning the configuration error a text
// gives, shared by the config tests.
#pragma once

#include <string>

#include "ndsid/config/config.h"

namespace ndsid::config::testing {

inline const char* kMinimal = R"(vehicle: {name: car, wheelbase_m: 2.6, mass_kg: 1500}
source: {type: log, logs: [a.log]}
dbc: b.dbc
signals:
  steering_wheel_angle: {message: M, signal: S, unit: deg}
  vehicle_speed: {message: M, signal: V, unit: km/h}
  lateral_acceleration: {message: M, signal: A, unit: m/s^2, sign: -1}
)";

// The error message ParseConfig throws for `yaml` (as car.yaml), "" when it parses.
inline std::string ErrorOf(const std::string& yaml) {
  try {
    ParseConfig(yaml, "car.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace ndsid::config::testing
