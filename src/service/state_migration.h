// Reading state files of format version 1 (ndsidd before the one codec, docs/state-format.md):
// their payload of sections ("meta", "accumulator" in the binary ACC1/ACC2 layout, "adequacy"
// and the statistics as text lines, "estimate" as key lines, "standstill" as JSON) becomes the
// document format version 2 holds, so one reader checks both. Nothing writes version 1.
#pragma once

#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace ndsid::service {

// Throws ndsid::Error (the caller makes it a corrupt-state error) for a malformed payload.
nlohmann::json MigrateStateV1(std::string_view payload);

}  // namespace ndsid::service
