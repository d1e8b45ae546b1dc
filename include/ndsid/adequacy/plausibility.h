// Plausibility: whether the data obey the kinematics every car obeys, and whether an estimate is
// physical and determined, before anyone trusts it (docs/monitoring.md). A wrong sign or unit in
// the configuration gives a fit that converges somewhere; these checks say so in words:
//   kinematics     a_y against v r (a_y = v (r + beta'), so the regression gain is 1): a flipped
//                  a_y or yaw-rate sign gives -1, a wrong speed or a_y unit 3.6, 1/3.6, 9.81 ...
//   steering sign  r against v d_sw: positive in ISO 8855 (steer left, turn left)
//   steer ratio    the steady-state ratio in a road vehicle's range (a rad/deg mix-up: x57)
//   EG range       the self-steering gradient in a road vehicle's range
//   determined     sigma(EG) not comparable to |EG|; not every free parameter on its bound
//   wheel_speed    vehicle_speed against the wheel speeds' mean (the optional wheel_speed role):
//                  equal within tyre tolerances; a unit mix-up gives 3.6, 1.61, 2.24 ...
// Checked on the identification window and on every drive in it (located messages, counters).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/stats/segment.h"

namespace ndsid::adequacy {

enum class Verdict { kPassed = 0, kFailed = 1, kSkipped = 2 };  // skipped: too little informative data

struct Check {
  std::string name;     // kinematics | steering_sign | steer_ratio | eg_range | determined
  Verdict verdict = Verdict::kSkipped;
  double value = 0;     // gain, correlation, ratio, EG [deg/g], sigma/|EG|
  double informative_s = 0;
  std::string message;  // the numbers and the likely cause, in words
  double value_se = 0;  // the value's standard error where the check has one (kinematics' gain), else 0
};

// One drive's data checks (kinematics, steering sign).
struct DriveChecks {
  int64_t drive_id = 0;
  int64_t t0_ns = 0;  // first sample of the drive in the window
  std::vector<Check> checks;
};

struct PlausibilityReport {
  std::vector<Check> checks;        // the window's data checks, then the estimate's
  std::vector<DriveChecks> drives;  // per drive
  int drives_failed = 0;            // drives failing a data check
  bool passed() const;              // no check failed
  bool undetermined() const;        // failed only for "determined"
  std::string Reason() const;       // the failed checks' messages, "; "-joined ("" when passed)
};

// The data checks on the window's segments (training and held-out alike), overall and per drive.
PlausibilityReport CheckData(const std::vector<const stats::Segment*>& segments, const config::PlausibilityConfig& limits);

// What the estimate adds: steady-state steer ratio (from the statistics; <= 0 when unknown),
// EG and its sigma [deg/g], and how many free base parameters ended on their bounds.
struct EstimateFacts {
  double steer_ratio = 0;
  double eg_deg_per_g = 0;
  double eg_se_deg_per_g = 0;
  int free_params = 0;
  int free_params_at_bound = 0;
};
void CheckEstimate(const EstimateFacts& facts, const config::PlausibilityConfig& limits, PlausibilityReport& report);

// vehicle_speed against the wheel speeds' mean, summed per drive on the reading path (the
// samples are not kept in the window's segments). Regression through the origin, v = ratio w.
struct SpeedSums {
  double sww = 0, svw = 0, svv = 0, seconds = 0;
  int64_t t0_ns = INT64_MAX;
  void Add(double v, double w, double dt, int64_t t_ns) {
    sww += w * w * dt, svw += v * w * dt, svv += v * v * dt, seconds += dt;
    if (t_ns < t0_ns) t0_ns = t_ns;
  }
};
// Adds the wheel_speed check (window and per drive) to `report`; nothing when no drive has sums.
void CheckWheelSpeed(const std::map<int64_t, SpeedSums>& by_drive, const config::PlausibilityConfig& limits,
                     PlausibilityReport& report);

const char* VerdictName(Verdict v);

}  // namespace ndsid::adequacy
