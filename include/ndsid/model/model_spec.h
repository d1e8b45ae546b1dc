// A model = the base single-track model + a list of effects, chosen in the YAML configuration
// (model: {effects: [steer_offset, roll]}) or on the command line. The daemon and every CLI
// command build it here, so they all use the same model definition.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ndsid/model/effect.h"
#include "ndsid/model/effect_library.h"

namespace ndsid::model {

class ModelSpec {
 public:
  ModelSpec() = default;
  // Throws ConfigError for an effect `library` does not have or a repeated name. Effects are
  // applied in the library's order (inputs -> tyres -> measurement, then formulas), whatever
  // the order of `names`.
  static ModelSpec FromNames(const std::vector<std::string>& names,
                             const EffectLibrary& library = EffectLibrary::Builtin());
  // The library the model was built from (discovery extends the model from the same set).
  const EffectLibrary& library() const { return library_; }

  const std::vector<std::shared_ptr<const Effect>>& effects() const { return effects_; }
  std::vector<std::string> effect_names() const;
  int num_params() const { return kNumParams + num_effect_params_; }  // base 6 + effects
  int num_effect_params() const { return num_effect_params_; }
  int num_states() const { return num_states_; }
  // Offsets of each effect's parameters / states in the full vectors.
  int param_offset(size_t effect) const { return param_offsets_[effect]; }
  int state_offset(size_t effect) const { return state_offsets_[effect]; }
  // Name and unit of parameter i of the full vector (base parameters first).
  std::string param_name(int i) const;
  std::string param_unit(int i) const;
  const EffectParam* effect_param(int i) const;  // nullptr for base parameters
  int param_index(const std::string& name) const;  // -1 when the model has no such parameter
  std::string Describe() const;  // "single-track + steer_offset + roll"

  // Indices (in the full vector) of the per-drive parameters (EffectParam::per_drive): each
  // drive has its own value; the vector holds the reference drive's (identify::DriveValue).
  const std::vector<int>& per_drive_params() const { return per_drive_params_; }

 private:
  EffectLibrary library_;
  std::vector<int> per_drive_params_;
  std::vector<std::shared_ptr<const Effect>> effects_;
  std::vector<int> param_offsets_, state_offsets_;
  int num_effect_params_ = 0;
  int num_states_ = 0;
};

}  // namespace ndsid::model
