// The daemon's estimator (daemon_estimator.h), and ndsidd's two one-shot commands on it:
// --check-config and --show-state (daemon.h).
#include "daemon_estimator.h"

#include <unistd.h>

#include <cstdio>

#include "daemon.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/publish/lcm_publisher.h"
#include "state_store.h"

namespace ndsid::service {

Estimator BuildEstimator(const std::string& path) {
  Estimator e;
  e.config = std::make_unique<config::Config>(config::LoadConfig(path));
  const config::Config& c = *e.config;
  try {
    e.db = std::make_unique<dbc::Database>(dbc::ParseDbcFile(c.dbc));
  } catch (const ConfigError&) {
    throw;
  } catch (const Error& err) {
    throw ConfigError(FormatLocation(c.path, 0, 0, std::string("dbc: ") + err.what()));
  }
  config::ValidateAgainstDbc(c, *e.db);
  if (c.source.type == config::SourceConfig::Type::kLog) {
    for (const std::string& log : c.source.logs) {
      if (::access(log.c_str(), R_OK) != 0) {
        throw ConfigError(FormatLocation(c.path, 0, 0, "source.logs: cannot read '" + log + "'"));
      }
      try {
        can::DetectLogFormat(log);  // a format we cannot read fails --check-config
      } catch (const Error& err) {
        throw ConfigError(FormatLocation(c.path, 0, 0, std::string("source.logs: ") + err.what()));
      }
    }
  }
  if (c.lcm.url.find("://") == std::string::npos) {
    throw ConfigError(FormatLocation(c.path, 0, 0, "lcm.url: '" + c.lcm.url + "' is not an LCM URL (e.g. udpm://239.255.76.67:7667?ttl=0)"));
  }
  e.pipeline = std::make_unique<pipeline::Pipeline>(c, *e.db);
  return e;
}

std::shared_ptr<publish::EstimateSink> MakeLcmSink(const config::Config& c) {
  return std::make_shared<publish::LcmPublisher>(c.lcm.url, publish::LcmChannels{c.lcm.estimate_channel,
                                                                                c.lcm.status_channel,
                                                                                c.lcm.monitor_channel});
}

void CheckConfig(const std::string& config_path) {
  const Estimator e = BuildEstimator(config_path);
  std::printf("%s: configuration OK (vehicle %s, DBC %s, %s)\n", config_path.c_str(), e.config->vehicle.name.c_str(),
              e.config->dbc.c_str(),
              e.config->source.type == config::SourceConfig::Type::kLog
                  ? (std::to_string(e.config->source.logs.size()) + " log file(s)").c_str()
                  : ("socketcan " + e.config->source.interface).c_str());
}

int ShowState(const std::string& config_path) {
  const config::Config c = config::LoadConfig(config_path);
  StateStore store(c.state_dir, c.vehicle.name);
  std::printf("state file: %s\n", store.path().c_str());
  LearnedState st;
  try {
    st = DecodeState(ReadWholeFile(store.path()), c.vehicle.name);
  } catch (const std::exception& e) {
    std::printf("not usable: %s\n", e.what());
    return 1;
  }
  stats::Accumulator acc(c, c.sync.rate_hz);
  try {
    acc.FromJson(JsonIn(st.accumulator, "state.accumulator"));
  } catch (const std::exception& e) {
    std::printf("not usable: %s\n", e.what());
    return 1;
  }
  size_t used = 0;
  for (const auto& d : acc.drives()) used += d.used ? 1 : 0;
  std::printf("vehicle: %s\ndata_time_s: %.6f\ngated_hours: %.6f\ndrives: %zu (%zu used)\nwindow: %zu segments, %.4f h\n"
              "identifications: %d\n",
              st.vehicle.c_str(), st.data_time_ns * 1e-9, acc.gated_hours(), acc.drives().size(), used, acc.window().size(),
              acc.window_hours(), st.identifications);
  {
    double seconds = 0;
    for (const gate::StandstillStop& s : st.stops) seconds += s.seconds;
    std::printf("standstill: %zu stops, %.2f s\n", st.stops.size(), seconds);
  }
  if (st.last_estimate) {
    const auto& f = st.last_estimate->fit;
    const std::string why = CheckEstimate(*st.last_estimate, c);
    std::printf("last estimate: valid=%d EG=%.9e rad/(m/s^2) sigma=%.3e EG_deg_per_g=%.6f%s%s\n", f.valid ? 1 : 0,
                f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.eg_deg_per_g, why.empty() ? "" : " REJECTED: ", why.c_str());
  } else {
    std::printf("last estimate: none\n");
  }
  return 0;
}

}  // namespace ndsid::service
