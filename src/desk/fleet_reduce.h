// The desk side of a fleet's per-log work (docs/fleet.md): a log (or a run of logs) read to its
// end by a fresh pipeline into a pipeline::LogReduction, and a vehicle's reductions merged in
// log order and identified, giving what `ndsid replay --final-only` over the same logs gives.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/pipeline/log_reduction.h"

namespace ndsid::desk {

// Reads `logs` in order through one fresh pipeline (recording its window steps) to their end.
// Throws Error naming a log that cannot be opened or stops early (truncated, corrupt), as
// `ndsid replay` does, and ConfigError for a file that is not a CAN log.
pipeline::LogReduction ReduceLogs(const config::Config& config, const dbc::Database& db, const std::vector<std::string>& logs);

// The reductions of a vehicle's logs (in log order) merged and identified with the final fit:
// the replay document (replay_document.h) with "runs" (the merged reductions' logs) added.
// Logs that do not continue cleanly from the log before them (pipeline::ContinuesCleanly) are
// read again together with it, so the result is the serial replay's in every case.
nlohmann::json IdentifyReduced(const config::Config& config, const dbc::Database& db,
                               std::vector<pipeline::LogReduction> reductions);

}  // namespace ndsid::desk
