// What the daemon publishes, composed from the pipeline: the estimate and status messages, the
// systemd STATUS= line and the final summary line.
// Thread: the reading thread (pure functions of the pipeline it owns).
#pragma once

#include <optional>
#include <string>

#include "ndsid/can/frame_source.h"
#include "ndsid/config/config.h"
#include "ndsid/publish/estimate_sink.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::service {

// `e` empty: no estimate yet (valid = false, reason says so).
publish::EstimateMessage MakeEstimateMessage(const std::optional<pipeline::Estimate>& e, const pipeline::Pipeline& pipeline,
                                             const config::Config& config, int32_t identifications);

struct SourceView {
  std::string description;
  can::SourceState state = can::SourceState::kOk;
  can::SourceCounters counters;
  uint64_t skipped_resume = 0;
};
publish::StatusMessage MakeStatusMessage(const pipeline::Pipeline& pipeline, const config::Config& config, const SourceView& source,
                                         bool identification_running, double last_persist_age_s);

const char* SourceStateName(can::SourceState s);

// "CONVERGING: EG 2.134e-03 rad/(m/s^2) = 1.20 deg/g +-1.3 %, 0.52 gated h" (systemd STATUS=).
std::string StatusLine(const std::optional<pipeline::Estimate>& e, const pipeline::Pipeline& pipeline);
// The line printed on stdout at the end of a replay (tests parse EG=).
std::string FinalLine(const std::optional<pipeline::Estimate>& e, const pipeline::Pipeline& pipeline);

}  // namespace ndsid::service
