// What a replay prints and what its report.md says about the final estimate: EG ± σ with its
// validity, every parameter, the RMSEs, adequacy and every check behind the validity, valid or
// not (a user must always see why), then the gate's counters and the share of accepted driving
// that reached the fit.
#pragma once

#include <string>

#include "ndsid/config/config.h"
#include "ndsid/pipeline/pipeline.h"
#include "replay_runner.h"

namespace ndsid::desk {

// The held-out yaw-rate RMSE in deg/s, or `none` without held-out data (-1).
std::string YawValidationText(double rmse_radps, const char* none);

// The markdown body of report.md about the final estimate (no heading, no file list).
std::string EstimateMarkdown(const ReplayOutcome& outcome);

// The gate's counters, every one (short_drive and short_segment included), and the share of the
// accepted time that reached the fit.
std::string GateLine(const config::Config& config, const pipeline::Pipeline& pipeline);

}  // namespace ndsid::desk
