#include "ndsid/model/effect_library.h"

#include <algorithm>

#include "effects/builtin_effects.h"
#include "ndsid/common/error.h"

namespace ndsid::model {

const std::shared_ptr<const std::vector<EffectLibrary::Entry>>& EffectLibrary::BuiltinEntries() {
  static const auto entries = [] {
    auto e = std::make_shared<std::vector<Entry>>();
    for (const std::string& name : BuiltinEffectNames()) e->push_back({name, MakeBuiltinEffect(name), true});
    return std::shared_ptr<const std::vector<Entry>>(std::move(e));
  }();
  return entries;
}

EffectLibrary::EffectLibrary() : entries_(BuiltinEntries()) {}

EffectLibrary::EffectLibrary(const std::vector<config::FormulaSpec>& formulas) {
  auto entries = std::make_shared<std::vector<Entry>>(*BuiltinEntries());
  for (const config::FormulaSpec& f : formulas) {
    const auto same = std::find_if(entries->begin(), entries->end(), [&](const Entry& e) { return e.name == f.name; });
    if (same != entries->end()) {
      throw ConfigError("model.formulas." + f.name + (same->builtin ? ": the name of a built-in effect" : ": listed twice"));
    }
    entries->push_back({f.name, MakeFormulaEffect(f), false});
  }
  entries_ = std::move(entries);
}

const EffectLibrary& EffectLibrary::Builtin() {
  static const EffectLibrary builtin;
  return builtin;
}

std::vector<std::string> EffectLibrary::names() const {
  std::vector<std::string> out;
  for (const Entry& e : *entries_) out.push_back(e.name);
  return out;
}

std::vector<std::string> EffectLibrary::builtin_names() const {
  std::vector<std::string> out;
  for (const Entry& e : *entries_) {
    if (e.builtin) out.push_back(e.name);
  }
  return out;
}

std::vector<std::string> EffectLibrary::formula_names() const {
  std::vector<std::string> out;
  for (const Entry& e : *entries_) {
    if (!e.builtin) out.push_back(e.name);
  }
  return out;
}

std::shared_ptr<const Effect> EffectLibrary::Find(const std::string& name) const {
  for (const Entry& e : *entries_) {
    if (e.name == name) return e.effect;
  }
  return nullptr;
}

std::shared_ptr<const Effect> EffectLibrary::Get(const std::string& name) const {
  if (auto effect = Find(name)) return effect;
  std::string known;
  for (const Entry& e : *entries_) known += (known.empty() ? "" : ", ") + e.name;
  throw ConfigError("unknown effect '" + name + "'; known effects: " + known);
}

}  // namespace ndsid::model
