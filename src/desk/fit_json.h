// One JSON form of an identification result, shared by every report (replay's estimate.json,
// compare's summary.json): EG with sigma in both units, every parameter (base then effects)
// as {name, value, se, unit, fixed, at_bound}, correlations, RMSE, identifiability.
#pragma once

#include <nlohmann/json.hpp>

#include "ndsid/identify/identifier.h"

namespace ndsid::desk {

nlohmann::json FitToJson(const identify::IdentificationResult& fit);

}  // namespace ndsid::desk
