// An estimate (the fit with the data behind it) as JSON, and back: the daemon's learned state
// keeps its last estimate in this form, and replay's estimate.json is this document with the
// run's facts added (docs/state-format.md). Also the window's standstill stops.
#pragma once

#include <vector>

#include "ndsid/common/json_codec.h"
#include "ndsid/gate/gate.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::pipeline {

// The fit's fields (identify::ResultToJson) at the top level, then gated_hours, window_hours,
// data_time_ns, training_segments, validation_segments, steady_state, adequacy, plausibility
// (its checks and the drives that failed one), standstill (stops, seconds, evidence) and, where
// the alternatives were refitted, model_choice (the kinematic gain, each alternative's name,
// fitted scale, EG, sigma, held-out RMSEs and whether the data rule it out; notes; seconds).
nlohmann::json EstimateToJson(const Estimate& e);
// Throws CodecError naming the path. The plausibility report comes back with its checks and
// its failed drives (the drives that passed are only counted in the document).
Estimate EstimateFromJson(const JsonIn& in);

// [{"drive", "t_start_ns", "seconds", "samples", "mean_lat_accel_mps2", "mean_yaw_rate_radps"
// (null: the bus had no yaw rate)}, ...]; at most `max_stops`, each checked for range.
nlohmann::json StopsToJson(const std::vector<gate::StandstillStop>& stops);
std::vector<gate::StandstillStop> StopsFromJson(const JsonIn& in, size_t max_stops);

}  // namespace ndsid::pipeline
