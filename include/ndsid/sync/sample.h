// A synchronised sample: every role interpolated to one instant on a fixed-rate grid.
#pragma once

#include <cstdint>

#include "ndsid/config/config.h"

namespace ndsid::sync {

struct Sample {
  int64_t t_ns = 0;
  double steer_rad = 0;          // steering-wheel angle d_sw, + left
  double speed_mps = 0;          // v
  double lat_accel_mps2 = 0;     // a_y as measured, + left
  double yaw_rate_radps = 0;     // r, + left (valid only if has_yaw_rate)
  double long_accel_mps2 = 0;    // a_x (valid only if has_long_accel)
  bool has_yaw_rate = false;
  bool has_long_accel = false;
  double wheel_speed_mps = 0;    // the wheel speeds' mean (valid only if has_wheel_speed)
  bool has_wheel_speed = false;
  double rear_wheel_diff_mps = 0;  // rear right minus rear left wheel speed (valid only if has_rear_wheel_diff)
  bool has_rear_wheel_diff = false;
  bool reverse = false;          // reverse gear engaged
  bool esc_active = false;       // ESC/ABS intervening
  bool valid = false;            // all required roles fresh and every validity flag says valid
  bool flags_invalid = false;    // a validity signal said "invalid" (or was stale)
  uint16_t stale_roles = 0;      // bit (1 << Role) per role that was stale or never seen
  bool gap_before = false;       // first sample after a bus silence longer than max_fill_gap_s

  double t_s() const { return static_cast<double>(t_ns) * 1e-9; }
};

}  // namespace ndsid::sync
