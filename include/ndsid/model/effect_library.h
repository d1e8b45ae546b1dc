// The effects a model may be built from: the built-in library (src/model/effects/) plus the
// formula effects of one configuration (model.formulas). A value, built once per configuration
// and passed explicitly to whoever builds models (pipeline, identify, discover, simulate, the
// desk commands, the daemon), so every entry point sees the same set; there is no global
// registry. A ModelSpec keeps the library it was built from, so discovery can extend a model
// with candidates from the same set.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/model/effect.h"

namespace ndsid::model {

class EffectLibrary {
 public:
  // The built-in effects only (shared, built once).
  EffectLibrary();
  // Built-ins + the formulas. Throws ConfigError naming the formula on a parse error, a
  // built-in's name, or a formula that does not reduce to the base model at its neutral values.
  explicit EffectLibrary(const std::vector<config::FormulaSpec>& formulas);
  // The built-in library as one shared immutable value (for callers without a configuration).
  static const EffectLibrary& Builtin();

  // Every effect, built-ins in application order (inputs -> dynamics -> measurement), then the
  // formulas in configuration order.
  std::vector<std::string> names() const;
  std::vector<std::string> builtin_names() const;
  std::vector<std::string> formula_names() const;
  // nullptr when the library has no effect of that name.
  std::shared_ptr<const Effect> Find(const std::string& name) const;
  // Throws ConfigError naming the effect and listing the known ones.
  std::shared_ptr<const Effect> Get(const std::string& name) const;

 private:
  struct Entry {
    std::string name;
    std::shared_ptr<const Effect> effect;
    bool builtin = true;
  };
  static const std::shared_ptr<const std::vector<Entry>>& BuiltinEntries();
  // Immutable and shared: copying a library (every ModelSpec keeps one) copies a pointer.
  std::shared_ptr<const std::vector<Entry>> entries_;
};

}  // namespace ndsid::model
