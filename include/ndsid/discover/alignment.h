// Step 0 of the diagnosis (physics.md §5): align the signals in time. Each role's latency
// relative to the lateral acceleration is estimated by a time-shift search, because a skew
// left in the data (10-150 ms of gateway latency is common) masquerades as a lag effect.
//   steering: profile of the model's RSS over shifts of the steering (parameters held), then a
//             joint refit of the model and the shift (the steer_delay term), which gives the
//             standard error with the parameters free (skipped when its first Gauss-Newton
//             step, the shift's score test, shows the shift below half the floor below: that
//             step and its standard error are reported instead; alignment.cc, JointLatency);
//   speed:    the same on the steering-aligned data, the joint refit with the speed_delay term;
//             when the speed's latency is applied, the steering once more on the speed-aligned
//             data (a 250 ms speed latency pulled the steering's shift by -14 ms), the two passes
//             of the steering added;
//   (both profiles score a_y: latencies are relative to a_y's)
//   yaw rate: with two outputs, the yaw-rate RSS profile over shifts of the measured yaw rate,
//             before the steering's (a gyro latency reaches a_y through the bank observer and
//             would pull the steering's shift) and after it (the sum is reported). With a_y alone
//             not estimated (listed with the reason): it drives only the bank observer, whose
//             1 s time constant makes a gateway skew immaterial, and its kinematic shift
//             (a_y = v (r + beta')) is confounded with the side-slip rate: tried, it found
//             +11 ms on exact synthetic data without skew.
// A latency is applied when it is determined (minimum inside the searched range), significant
// (|latency| > z_apply standard errors, autocorrelation-corrected) and at least min_apply_s (by
// default half the fit's sample interval, 10 ms at 50 Hz: the discrete model's timing is no
// finer, and its standard error covers noise, not model error: on clean simulated drives with
// a_y and the yaw rate in one message the yaw-rate profile found -6.7 +- 0.4 and +6.9 +- 0.3 ms,
// the steering's -5.4 +- 0.3 ms, all applied before this floor).
#pragma once

#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"

namespace ndsid::discover {

struct RoleLatency {
  config::Role role = config::Role::kSteeringWheelAngle;
  double latency_s = 0;     // the role's value is stamped this much later than a_y's
  double se_s = 0;          // standard error (0 when not determined)
  bool determined = false;  // a minimum inside the searched range, finite standard error
  bool apply = false;       // determined and significant: the data are shifted by it
  std::string method;       // how it was estimated
  std::string note;         // why not determined / not applied ("" otherwise)
};

struct AlignmentOptions {
  double min_s = -0.1;   // searched shifts (the steer_delay box)
  double max_s = 0.3;
  double step_s = 0.01;  // grid of the profile; the minimum is refined by a parabola
  double z_apply = 3.0;  // |latency| / se needed before the data are shifted
  double min_apply_s = -1;  // |latency| needed before the data are shifted; < 0: half the sample interval
};

// params: full vector of identifier.spec() fitted on `training` (unaligned).
std::vector<RoleLatency> EstimateRoleLatencies(const identify::Identifier& identifier, const std::vector<double>& params,
                                               const identify::SegmentList& training, const AlignmentOptions& options = {});

// Copies of the segments with every role marked `apply` read at t + latency (linear
// interpolation): what the sync stage produces with signals.<role>.latency_s set to those
// values. The samples whose read would fall outside their segment are dropped (a held end value
// there, what this did before, left a 150 ms gyro latency's aligned yaw-rate fit at 0.13 deg/s
// against 0.07 through the sync stage); a segment's t0 moves with the samples dropped in front.
std::vector<stats::Segment> AlignSegments(const identify::SegmentList& segments, const std::vector<RoleLatency>& latencies);


}  // namespace ndsid::discover
