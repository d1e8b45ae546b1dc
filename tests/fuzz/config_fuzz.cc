// Fuzz target: a vehicle YAML through ParseConfig, then its formula effects through the model's
// registration (parse, limits, the neutral-value check, one evaluation each), the effect list
// through ModelSpec and model.alternatives through their check against it. Only ConfigError (a
// located error, exit 78) may come out.
#include <cstdint>
#include <string>

#include "ndsid/config/config.h"
#include "ndsid/model/effect.h"
#include "ndsid/model/model_spec.h"
#include "ndsid/pipeline/model_choice.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ndsid::config::Config c = ndsid::config::ParseConfig(text, "/fuzz/vehicle.yaml");
    const ndsid::model::EffectLibrary library(c.model_formulas);
    ndsid::model::ModelSpec::FromNames(c.model_effects);
    ndsid::pipeline::CheckAlternatives(c.model_alternatives, c.model_effects, library);
    ndsid::pipeline::CheckWatched(c.model_watch, library);
  } catch (const ndsid::ConfigError&) {
  }
  return 0;
}
