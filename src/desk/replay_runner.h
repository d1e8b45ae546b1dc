// Runs one set of recorded drives through the pipeline (the CLI's `replay` and `study` use it),
// and writes the report folder.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ndsid/can/frame_source.h"
#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::desk {

struct ReplayOptions {
  std::vector<std::string> logs;  // overrides config.source.logs when not empty
  bool identify_periodically = true;  // fit every identification.period_s (EG history) or only at the end
};

struct ReplayOutcome {
  std::string name;
  can::SourceCounters source;  // summed over logs
  uint64_t malformed_reported = 0;
  std::optional<pipeline::Estimate> final_estimate;
  std::vector<pipeline::Estimate> history;
  std::optional<double> truth_eg;  // from a truth.yaml beside the log, if any
  std::vector<std::string> input_errors;  // "path: reason" of each log not read to its end
  double wall_s = 0;              // the whole replay, final identification included
  double periodic_fit_wall_s = 0; // the periodic re-identifications' own time (daemon's schedule)
  double periodic_fit_wait_s = 0; // of the wall time: the reading waiting for a periodic fit to end
  size_t periodic_fits_queued = 0; // periodic fits due while the last one ran (snapshot taken, fitted after it)
};

// Replays the logs through `pipeline` (built from `config`); throws Error at set-up only
// (a log that cannot be opened).
ReplayOutcome RunReplay(pipeline::Pipeline& pipeline, const config::Config& config, const ReplayOptions& options);

// Writes report.md, estimate.json, eg_history.csv, drives.csv, gate.csv (+ PNG plots when the
// project's Python venv is available) into dir; returns the path of report.md.
std::string WriteReport(const std::string& dir, const config::Config& config, const pipeline::Pipeline& pipeline,
                        const ReplayOutcome& outcome);

// Prints the summary block for one replay to stdout.
void PrintSummary(const config::Config& config, const pipeline::Pipeline& pipeline, const ReplayOutcome& outcome,
                  const std::string& report_path);

}  // namespace ndsid::desk
