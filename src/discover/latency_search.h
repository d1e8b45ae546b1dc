// Step 0's search for one role's latency (alignment.h, EstimateRoleLatencies reads these): the
// profile of the model's RSS over shifts of the role, then the joint refit of the model and the
// shift (its delay effect), or, when the shift's score test shows it below the floor, that test's
// one step alone.
#pragma once

#include <string>
#include <vector>

#include "ndsid/discover/alignment.h"

namespace ndsid::discover {

// Copies of the segments with every role marked `apply` read at t + latency (linear
// interpolation). trim: the samples whose read would fall outside their segment are dropped
// (the ends the sync stage would not have: it shifts the signals before the gate cuts segments);
// else they hold the segment's end value, so that every shift scores the same samples (profiles).
std::vector<stats::Segment> Shifted(const identify::SegmentList& segments, const std::vector<RoleLatency>& latencies, bool trim);

// Yaw rate (two outputs): the profile of the yaw-rate RSS over shifts of the measured yaw rate
// (the output and what the bank observer reads), parameters held.
RoleLatency YawRateProfile(const identify::Identifier& two, const std::vector<double>& params,
                           const identify::SegmentList& training, const AlignmentOptions& o);

// The latency of `role` (its delay effect `effect`: steer_delay, speed_delay, gyro_delay) from the
// fit `params` of `id` on `training`; `nuisance`: effects fitted along; `floor_s`: the smallest
// latency applied; `refitted`: the model's parameters from the joint refit (when one was made).
RoleLatency JointLatency(const identify::Identifier& id, const std::vector<double>& params, const identify::SegmentList& training,
                         config::Role role, const std::string& effect, const std::vector<std::string>& nuisance,
                         const AlignmentOptions& o, double floor_s, std::vector<double>& refitted);

}  // namespace ndsid::discover
