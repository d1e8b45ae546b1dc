// Fuzz target: a simulation YAML through ParseSimulationConfig (every key, the bus's message
// cycles and frame loss, the effects and their ranges). Only ConfigError (a located error) may
// come out.
#include <cstdint>
#include <string>

#include "ndsid/common/error.h"
#include "ndsid/config/simulation_config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    ndsid::config::ParseSimulationConfig(text, "/fuzz/sim.yaml");
  } catch (const ndsid::ConfigError&) {
  }
  return 0;
}
