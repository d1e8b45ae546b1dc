// The replay's result as one JSON document (what `ndsid.replay` returns in Python, and each
// vehicle's result of `ndsid fleet`): the final estimate with its history, the drives, the
// gate's counters, the window, the frames and the truth EG of simulated data.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ndsid/gate/gate.h"
#include "ndsid/pipeline/pipeline.h"
#include "replay_runner.h"

namespace ndsid::desk {

// `gate`: the verdict counts of the samples read (the pipeline's own gate when it read them).
nlohmann::json ReplayDocument(const pipeline::Pipeline& pipeline, const ReplayOutcome& outcome, const gate::GateCounters& gate);

// The truth EG [rad/(m/s^2)] of simulated data: a truth.yaml beside the first log, if any.
std::optional<double> TruthBesideLogs(const std::vector<std::string>& logs);

}  // namespace ndsid::desk
