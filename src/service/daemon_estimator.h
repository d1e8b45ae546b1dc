// The daemon's estimator: the configuration, its DBC and the pipeline built on them, loaded and
// checked together (at start, on --check-config, and on a SIGHUP reload, which replaces all three
// at once). Thread: the reading thread (and main, before it starts).
#pragma once

#include <memory>
#include <string>

#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/pipeline/pipeline.h"
#include "ndsid/publish/estimate_sink.h"

namespace ndsid::service {

struct Estimator {
  std::unique_ptr<config::Config> config;       // the configuration file, loaded
  std::unique_ptr<dbc::Database> db;            // its DBC
  std::unique_ptr<pipeline::Pipeline> pipeline; // built on both
};

// Loads the configuration and the DBC, checks them against each other, the log files and the
// LCM URL, and builds the pipeline. Throws ConfigError naming file:line (exit 78).
Estimator BuildEstimator(const std::string& path);

// The LCM publisher of the configuration's lcm section.
std::shared_ptr<publish::EstimateSink> MakeLcmSink(const config::Config& c);

}  // namespace ndsid::service
