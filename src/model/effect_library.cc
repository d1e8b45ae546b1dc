#include "ndsid/model/effect_library.h"

#include <algorithm>

#include "effects/builtin_effects.h"
#include "ndsid/common/error.h"

namespace ndsid::model {

EffectLibrary::EffectLibrary() {
  for (const std::string& name : BuiltinEffectNames()) entries_.push_back({name, MakeBuiltinEffect(name), true});
}

EffectLibrary::EffectLibrary(const std::vector<config::FormulaSpec>& formulas) : EffectLibrary() {
  for (const config::FormulaSpec& f : formulas) {
    if (Find(f.name)) {
      const bool builtin = std::find(BuiltinEffectNames().begin(), BuiltinEffectNames().end(), f.name) !=
                           BuiltinEffectNames().end();
      throw ConfigError("model.formulas." + f.name + (builtin ? ": the name of a built-in effect" : ": listed twice"));
    }
    entries_.push_back({f.name, MakeFormulaEffect(f), false});
  }
}

const EffectLibrary& EffectLibrary::Builtin() {
  static const EffectLibrary builtin;
  return builtin;
}

std::vector<std::string> EffectLibrary::names() const {
  std::vector<std::string> out;
  for (const Entry& e : entries_) out.push_back(e.name);
  return out;
}

std::vector<std::string> EffectLibrary::builtin_names() const {
  std::vector<std::string> out;
  for (const Entry& e : entries_) {
    if (e.builtin) out.push_back(e.name);
  }
  return out;
}

std::vector<std::string> EffectLibrary::formula_names() const {
  std::vector<std::string> out;
  for (const Entry& e : entries_) {
    if (!e.builtin) out.push_back(e.name);
  }
  return out;
}

std::shared_ptr<const Effect> EffectLibrary::Find(const std::string& name) const {
  for (const Entry& e : entries_) {
    if (e.name == name) return e.effect;
  }
  return nullptr;
}

std::shared_ptr<const Effect> EffectLibrary::Get(const std::string& name) const {
  if (auto effect = Find(name)) return effect;
  std::string known;
  for (const Entry& e : entries_) known += (known.empty() ? "" : ", ") + e.name;
  throw ConfigError("unknown effect '" + name + "'; known effects: " + known);
}

}  // namespace ndsid::model
