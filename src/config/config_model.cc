// The configuration's model section: the effects, the formula effects and the priors.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "config_sections.h"

namespace ndsid::config {
namespace {

// model.formulas.<name>.parameters.<pname>
FormulaParam ReadFormulaParam(const YamlReader& ps, const std::string& pname) {
  const YamlReader pr = ps.Child(pname);
  FormulaParam fp;
  fp.name = pname;
  fp.lower = pr.Number("min");
  CheckRange(pr, "min", fp.lower, -kMaxPhysical, kMaxPhysical);
  fp.upper = pr.Number("max");
  CheckRange(pr, "max", fp.upper, -kMaxPhysical, kMaxPhysical);
  fp.neutral = Ranged(pr, "neutral", 0.0, -kMaxPhysical, kMaxPhysical);
  fp.initial = Ranged(pr, "initial", fp.neutral, -kMaxPhysical, kMaxPhysical);
  fp.unit = pr.String("unit", "-");
  pr.Finish();
  if (fp.upper > fp.lower && (fp.neutral < fp.lower || fp.neutral > fp.upper)) {
    std::ostringstream why;
    why << "neutral " << fp.neutral << " lies outside [" << fp.lower << ", " << fp.upper
        << "]: the base model (every parameter at its neutral value) must lie inside the box";
    ps.Fail(pname, why.str());
  }
  if (!(fp.upper > fp.lower) || fp.initial < fp.lower || fp.initial > fp.upper) {
    ps.Fail(pname, "needs min < max and min <= initial <= max");
  }
  return fp;
}

// model.formulas.<name>: one or more targets (kFormulaTargets), sharing the parameters.
FormulaSpec ReadFormula(const YamlReader& fs, const std::string& name) {
  const YamlReader f = fs.Child(name);
  FormulaSpec spec;
  spec.name = name;
  spec.file = fs.file();
  spec.line = fs.Line(name);
  for (const char* target : kFormulaTargets) {
    if (f.Has(target)) {
      spec.targets.push_back({target, f.String(target)});
    } else {
      f.Raw(target);
    }
  }
  if (spec.targets.empty()) {
    fs.Fail(name, "needs one or more of a_y_meas, r_meas, beta_dot, r_dot, alpha_v, alpha_h, F_v, F_h");
  }
  if (f.Has("parameters")) {
    const YamlReader ps = f.Child("parameters");
    for (const auto& pkv : ps.node()) spec.params.push_back(ReadFormulaParam(ps, pkv.first.as<std::string>()));
    ps.Finish();
  } else {
    f.Raw("parameters");
  }
  if (spec.params.empty()) fs.Fail(name, "a formula effect needs at least one parameter");
  f.Finish();
  return spec;
}

// model.priors.<name>: value and sd.
ParameterPrior ReadPrior(const YamlReader& ps, const std::string& name) {
  const YamlReader pr = ps.Child(name);
  ParameterPrior prior;
  prior.name = name;
  prior.value = pr.Number("value");
  CheckRange(pr, "value", prior.value, -kMaxPhysical, kMaxPhysical);
  prior.sd = pr.Number("sd");
  CheckRange(pr, "sd", prior.sd, 0, kMaxPhysical);
  prior.location = ps.file() + ":" + std::to_string(ps.Line(name));
  pr.Finish();
  if (!(prior.sd > 0) || !std::isfinite(prior.value)) ps.Fail(name, "a prior needs a finite value and sd > 0");
  return prior;
}

}  // namespace

void ReadModel(const YamlReader& m, Config& c) {
  c.model_effects = m.Strings("effects", {});
  c.model_alternatives = m.Strings("alternatives", {});
  if (c.model_alternatives.size() > kMaxAlternatives)
    m.Fail("alternatives", "at most " + std::to_string(kMaxAlternatives) + " alternatives (each is one more fit of the window per estimate)");
  c.model_watch = m.Strings("watch", c.model_watch);
  if (c.model_watch.size() > kMaxWatched)
    m.Fail("watch", "at most " + std::to_string(kMaxWatched) + " watched effects (each is one score test per estimate)");
  if (m.Has("formulas")) {
    const YamlReader fs = m.Child("formulas");
    for (const auto& kv : fs.node()) c.model_formulas.push_back(ReadFormula(fs, kv.first.as<std::string>()));
    fs.Finish();
  } else {
    m.Raw("formulas");
  }
  if (m.Has("priors")) {
    const YamlReader ps = m.Child("priors");
    for (const auto& kv : ps.node()) c.identification.priors.push_back(ReadPrior(ps, kv.first.as<std::string>()));
    ps.Finish();
  } else {
    m.Raw("priors");
  }
  m.Finish();
}

}  // namespace ndsid::config
