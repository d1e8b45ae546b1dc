// An identification result as JSON, and back: the one form every writer uses (the daemon's
// learned state, replay's estimate.json, compare's summary.json, diagnose's diagnosis.json).
// EG with sigma in both units, every parameter (base then effects) as {name, value, se, unit,
// fixed, at_bound}, the outputs fitted and their RMSEs and noise levels, correlations,
// identifiability, and the per-drive parameters' values per drive (docs/state-format.md; the
// "drive_loads" of older documents read as load_ratio values).
#pragma once

#include "ndsid/common/json_codec.h"
#include "ndsid/identify/identifier.h"

namespace ndsid::identify {

nlohmann::json ResultToJson(const IdentificationResult& result);
// Throws CodecError naming the path of the first missing or malformed value. Values are read
// as written (non-finite ones too): whether an estimate may be used is its reader's check.
IdentificationResult ResultFromJson(const JsonIn& in);

}  // namespace ndsid::identify
