#include "ndsid/config/truth_file.h"

#include <yaml-cpp/yaml.h>

#include <sstream>

#include "ndsid/common/error.h"

namespace ndsid::config {

std::optional<double> ReadTruthNumber(const std::string& path, const std::string& dotted_key) {
  YAML::Node node;
  try {
    node = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw ConfigError(FormatLocation(path, e.mark.line + 1, e.mark.column + 1, e.msg));
  }
  std::istringstream keys(dotted_key);
  std::string key;
  while (std::getline(keys, key, '.')) {
    if (!node.IsMap() || !node[key]) return std::nullopt;
    node = node[key];
  }
  try {
    return node.as<double>();
  } catch (const YAML::Exception&) {
    return std::nullopt;
  }
}

std::optional<double> ReadTruthEg(const std::string& path) {
  for (const char* key : {"vehicle.self_steer_gradient_rad_per_mps2", "eg_rad_per_mps2", "vehicle.eg_rad_per_mps2"}) {
    if (auto v = ReadTruthNumber(path, key)) return v;
  }
  return std::nullopt;
}

}  // namespace ndsid::config
