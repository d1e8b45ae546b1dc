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
  std::string Describe() const;  // "single-track + steer_offset + roll"

  // "load_change" (physics.md §4, mass / load change): one load ratio per drive, m and Jz of
  // drive d scaled by rho_d (equivalently its tyre forces by 1/rho_d), relative to a reference
  // drive. Per-drive values are not part of the fixed parameter vector: the identifier
  // estimates them (Identifier::Identify) and carries them in the result.
  static constexpr const char* kLoadChange = "load_change";
  bool per_drive_load() const { return per_drive_load_; }

 private:
  EffectLibrary library_;
  bool per_drive_load_ = false;
  std::vector<std::shared_ptr<const Effect>> effects_;
  std::vector<int> param_offsets_, state_offsets_;
  int num_effect_params_ = 0;
  int num_states_ = 0;
};

}  // namespace ndsid::model
