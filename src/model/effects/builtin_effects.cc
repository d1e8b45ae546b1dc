// The table of built-in effects. The table's order is the order effects are applied in:
// inputs, then dynamics (slip lag before tyre saturation), then measurement terms.
#include "builtin_effects.h"

#include <string>
#include <utility>
#include <vector>


namespace ndsid::model {
namespace {

using Factory = std::shared_ptr<const Effect> (*)();
const std::vector<std::pair<std::string, Factory>>& Table() {
  static const std::vector<std::pair<std::string, Factory>> table = {
      {"steer_offset", MakeSteerOffset},       // inputs
      {"steer_delay", MakeSteerDelay},
      {"speed_delay", MakeSpeedDelay},         // the speed read tau later, then offset and scale
      {"speed_offset", MakeSpeedOffset},       // v_meas - c, then / (1 + eps)
      {"speed_scale", MakeSpeedScale},
      {"crossfall", MakeCrossfall},            // dynamics
      {"road_bank", MakeRoadBank},
      {"superelevation", MakeSuperelevation},
      {"relaxation", MakeRelaxation},
      {"tyre_saturation", MakeTyreSaturation},
      {"load_change", MakeLoadChange},         // per drive: the tyre forces / rho, after the tyre model
      {"accel_bias", MakeAccelBias},           // measurement
      {"accel_scale", MakeAccelScale},
      {"lever_arm", MakeLeverArm},
      {"roll", MakeRoll},
      {"gyro_offset", MakeGyroOffset},         // yaw-rate measurement (offset before scale)
      {"gyro_offset_per_drive", MakeGyroOffsetPerDrive},  // the same, one offset per drive
      {"gyro_scale", MakeGyroScale},
      {"gyro_delay", MakeGyroDelay},
  };
  return table;
}

}  // namespace

std::vector<std::string> BuiltinEffectNames() {
  std::vector<std::string> names;
  for (const auto& [name, f] : Table()) names.push_back(name);
  return names;
}

std::shared_ptr<const Effect> MakeBuiltinEffect(const std::string& name) {
  for (const auto& [n, f] : Table()) {
    if (n == name) return f();
  }
  return nullptr;
}

}  // namespace ndsid::model
