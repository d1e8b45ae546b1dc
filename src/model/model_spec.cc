#include "ndsid/model/model_spec.h"

#include <algorithm>

#include "ndsid/common/error.h"

namespace ndsid::model {

ModelSpec ModelSpec::FromNames(const std::vector<std::string>& names, const EffectLibrary& library) {
  const std::vector<std::string> order = library.names();
  for (size_t i = 0; i < names.size(); ++i) {
    if (std::find(names.begin(), names.begin() + static_cast<long>(i), names[i]) != names.begin() + static_cast<long>(i)) {
      throw ConfigError("effect '" + names[i] + "' listed twice");
    }
  }
  std::vector<std::string> sorted = names;
  std::stable_sort(sorted.begin(), sorted.end(), [&](const std::string& a, const std::string& b) {
    return std::find(order.begin(), order.end(), a) < std::find(order.begin(), order.end(), b);
  });
  ModelSpec spec;
  spec.library_ = library;
  int p = kNumParams, s = 0;
  for (const std::string& name : sorted) {
    auto effect = library.Get(name);
    for (size_t i = 0; i < effect->info().params.size(); ++i) {
      if (effect->info().params[i].per_drive) spec.per_drive_params_.push_back(p + static_cast<int>(i));
    }
    spec.param_offsets_.push_back(p);
    spec.state_offsets_.push_back(s);
    p += static_cast<int>(effect->info().params.size());
    s += effect->info().num_states;
    spec.effects_.push_back(std::move(effect));
  }
  // One parameter, one meaning: two effects with a parameter of the same name (gyro_offset and
  // gyro_offset_per_drive) are alternatives, not a combination.
  for (size_t a = 0; a < spec.effects_.size(); ++a)
    for (size_t b = 0; b < a; ++b)
      for (const auto& pa : spec.effects_[a]->info().params)
        for (const auto& pb : spec.effects_[b]->info().params)
          if (pa.name == pb.name)
            throw ConfigError("effects '" + spec.effects_[b]->info().name + "' and '" + spec.effects_[a]->info().name +
                              "' share the parameter '" + pa.name + "': list one of them");
  spec.num_effect_params_ = p - kNumParams;
  spec.num_states_ = s;
  return spec;
}

std::vector<std::string> ModelSpec::effect_names() const {
  std::vector<std::string> out;
  for (const auto& e : effects_) out.push_back(e->info().name);
  return out;
}

const EffectParam* ModelSpec::effect_param(int i) const {
  for (size_t e = 0; e < effects_.size(); ++e) {
    const int off = param_offsets_[e];
    const auto& params = effects_[e]->info().params;
    if (i >= off && i < off + static_cast<int>(params.size())) return &params[static_cast<size_t>(i - off)];
  }
  return nullptr;
}

int ModelSpec::param_index(const std::string& name) const {
  for (int i = 0; i < num_params(); ++i)
    if (param_name(i) == name) return i;
  return -1;
}

std::string ModelSpec::param_name(int i) const {
  if (i < kNumParams) return kParamNames[i];
  const EffectParam* p = effect_param(i);
  return p ? p->name : "?";
}

std::string ModelSpec::param_unit(int i) const {
  if (i < kNumParams) return kParamUnits[i];
  const EffectParam* p = effect_param(i);
  return p ? p->unit : "?";
}

std::string ModelSpec::Describe() const {
  std::string d = "single-track";
  for (const auto& e : effects_) d += " + " + e->info().name;
  return d;
}

}  // namespace ndsid::model
