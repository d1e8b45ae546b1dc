// Reading the simulator's truth file (YAML) where the tools compare an estimate with it.
#pragma once

#include <optional>
#include <string>

namespace ndsid::config {

// The true self-steering gradient [rad/(m/s^2)] of a simulator truth file, or nullopt when the
// file has none. Throws ConfigError when the file cannot be read or parsed.
std::optional<double> ReadTruthEg(const std::string& path);

// A number at a dotted key path ("vehicle.eg_rad_per_mps2"), or nullopt.
std::optional<double> ReadTruthNumber(const std::string& path, const std::string& dotted_key);

}  // namespace ndsid::config
