// The daemon tests' configuration: daemon_vehicle.yaml.in with its placeholders filled.
#pragma once

#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "ndsid/config/config.h"

namespace ndsid::testing {

inline std::string DaemonTestYaml(std::map<std::string, std::string> values) {
  std::ifstream in(std::string(NDSID_SOURCE_DIR) + "/tests/integration/daemon_vehicle.yaml.in");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  values.emplace("VEHICLE", "daemon-test-car");
  values.emplace("SOURCE_TYPE", "log");
  values.emplace("SOURCE", "  logs: [/dev/null]");
  values.emplace("DBC", std::string(NDSID_SOURCE_DIR) + "/dbc/ndsid_example.dbc");
  values.emplace("PERIOD_S", "60");
  values.emplace("MIN_DRIVE_KM", "2.0");
  values.emplace("LCM_URL", "memq://");
  values.emplace("STATE_DIR", "/nonexistent");
  values.emplace("CHANNEL_PREFIX", "NDSID_");
  values.emplace("MONITOR_RATE_HZ", "10");
  for (const auto& [key, value] : values) {
    const std::string token = "@" + key + "@";
    for (size_t pos; (pos = text.find(token)) != std::string::npos;) text.replace(pos, token.size(), value);
  }
  return text;
}

inline config::Config DaemonTestConfig(std::map<std::string, std::string> values = {}) {
  return config::ParseConfig(DaemonTestYaml(std::move(values)), "daemon_vehicle.yaml");
}

}  // namespace ndsid::testing
