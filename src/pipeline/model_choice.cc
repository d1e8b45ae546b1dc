#include "ndsid/pipeline/model_choice.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "ndsid/common/error.h"
#include "ndsid/common/format.h"
#include "ndsid/discover/diagnosis.h"
#include "ndsid/pipeline/pipeline.h"
#include "ndsid/stats/speed_scale.h"
#include "ndsid/stats/wheel_yaw.h"

namespace ndsid::pipeline {
namespace {

constexpr double kDegPerRad = 180.0 / M_PI;
// The speed scale from a_x against dv/dt decides the speed attribution when it is consistent
// with 0 within this many of its sd and excludes the attributed scale by as many.
constexpr double kSpeedEvidenceZ = 2.0;

// The window-level kinematics check (the first of that name: the per-drive ones are in `drives`).
const adequacy::Check* Kinematics(const adequacy::PlausibilityReport& r) {
  for (const adequacy::Check& c : r.checks)
    if (c.name == "kinematics") return &c;
  return nullptr;
}

// The published fit's held-out RMSEs (training where nothing is held out): a_y [m/s^2], yaw rate [rad/s].
std::pair<double, double> HeldOutRmse(const identify::IdentificationResult& f) {
  const double a = f.rmse_validation_mps2 >= 0 ? f.rmse_validation_mps2 : f.rmse_train_mps2;
  const double r = f.rmse_validation_yaw_radps >= 0 ? f.rmse_validation_yaw_radps : f.rmse_train_yaw_radps;
  return {a, r};
}

// Whether a_x against dv/dt decides the speed scale against the attribution eps (note in `why`).
bool SpeedScaleDecided(const std::vector<const stats::Segment*>& window, double eps, std::string& why) {
  const stats::SpeedScaleEvidence ev = stats::EstimateSpeedScale(window);
  if (!ev.available || !(ev.prior_sd > 0)) return false;
  const bool zero = std::abs(ev.scale) <= kSpeedEvidenceZ * ev.prior_sd;
  const bool excludes = std::abs(ev.scale - eps) > kSpeedEvidenceZ * ev.prior_sd;
  if (!(zero && excludes)) return false;
  why = Fmt("speed_scale left out: a_x against dv/dt gives %+.2f +- %.2f %%, consistent with 0 and not %+.2f %%",
            100 * ev.scale, 100 * ev.prior_sd, 100 * eps);
  return true;
}

// The index in `spec` of `effect`'s first parameter (-1: the model lacks it or it has none).
int FirstParam(const model::ModelSpec& spec, const std::string& effect) {
  for (size_t i = 0; i < spec.effects().size(); ++i) {
    if (spec.effects()[i]->info().name != effect || spec.effects()[i]->info().params.empty()) continue;
    return spec.param_offset(i);
  }
  return -1;
}

// One refit of the window with `effect` (added to the model when it lacks it) free. A scale
// attribution starts its scale at `value` (the scale the fit ends on is the alternative's); a
// configured alternative (no value) starts at the effect's initial values, and its first parameter's
// value is the alternative's. held: the scale held at `value` (the alternative named effect +
// kHeldSuffix).
ModelAlternative Refit(const identify::Identifier& identifier, const WindowSnapshot& snap,
                       const identify::IdentificationResult& fit, const std::string& effect, std::optional<double> value,
                       const std::optional<config::ParameterPrior>& prior, bool held = false) {
  ModelAlternative alt{.name = held ? effect + kHeldSuffix : effect, .scale = value.value_or(0), .configured = !value};
  const model::ModelSpec& spec = identifier.spec();
  std::vector<std::string> names = spec.effect_names();
  if (std::find(names.begin(), names.end(), effect) == names.end()) names.push_back(effect);
  config::IdentificationConfig cfg = identifier.config();
  if (prior) {  // the evidence's prior replaces a configured one on the same parameter
    std::erase_if(cfg.priors, [&](const config::ParameterPrior& p) { return p.name == prior->name; });
    cfg.priors.push_back(*prior);
  }
  if (held && value) cfg.fixed_effect_params.emplace_back(effect, *value);
  try {
    const model::ModelSpec alt_spec = model::ModelSpec::FromNames(names, spec.library());
    identify::Identifier id(cfg, identifier.wheelbase_m(), alt_spec);
    id.set_standstill(snap.standstill);
    id.set_drive_values(fit.drive_values);
    std::vector<double> start = fit.ValuesFor(alt_spec);
    const int k = value ? alt_spec.param_index(effect) : FirstParam(alt_spec, effect);
    if (value && k >= 0 && k < static_cast<int>(start.size())) start[k] = *value;
    if (!value && k >= 0) alt.parameter = alt_spec.param_name(k) + " [" + alt_spec.param_unit(k) + "]";
    const identify::IdentificationResult r = id.Identify(snap.training, snap.validation, start);
    if (k >= model::kNumParams && k < static_cast<int>(r.effect_params.size()) + model::kNumParams)
      alt.scale = r.effect_params[k - model::kNumParams].value;
    if (!r.valid) {
      alt.reason = r.reason;
      return alt;
    }
    alt.fitted = true;
    alt.eg_deg_per_g = r.eg_deg_per_g;
    alt.eg_se_deg_per_g = r.eg_se_deg_per_g;
    const auto [a, yaw] = HeldOutRmse(r);
    alt.rmse_a_y_mps2 = a;
    alt.rmse_yaw_degps = yaw >= 0 ? yaw * kDegPerRad : -1;
    alt.result = std::make_shared<const identify::IdentificationResult>(r);
  } catch (const std::exception& e) {  // an effect the library lacks, out of memory
    alt.reason = e.what();
  }
  return alt;
}

// Rules an alternative out when the data contradict it: a held-out RMSE clearly worse than the
// published fit's, or no fit at all.
void JudgeAgainstFit(const identify::IdentificationResult& fit, ModelAlternative& alt) {
  if (!alt.fitted) {
    alt.ruled_out = true;
    alt.ruled_out_why = "not fitted: " + alt.reason;
    return;
  }
  const auto [a, yaw] = HeldOutRmse(fit);
  if (a > 0 && alt.rmse_a_y_mps2 > kRuledOutRmseRatio * a) {
    alt.ruled_out = true;
    alt.ruled_out_why = Fmt("a_y RMSE %.4g m/s^2 = %.3f x the fit's", alt.rmse_a_y_mps2, alt.rmse_a_y_mps2 / a);
  } else if (yaw > 0 && alt.rmse_yaw_degps > kRuledOutRmseRatio * yaw * kDegPerRad) {
    alt.ruled_out = true;
    alt.ruled_out_why = Fmt("yaw-rate RMSE %.4g deg/s = %.3f x the fit's", alt.rmse_yaw_degps, alt.rmse_yaw_degps / (yaw * kDegPerRad));
  }
}

// A fit's value of an effect parameter (0: the model lacks it).
double EffectValue(const identify::IdentificationResult& f, const std::string& name) {
  for (const identify::ParameterEstimate& p : f.effect_params)
    if (p.name == name) return p.value;
  return 0;
}

// The gyro's scale against the rear wheels that a model predicts: s = (1 + k_r)/(1 + eps).
double PredictedWheelScale(double gyro_scale, double speed_scale) { return (1 + gyro_scale) / (1 + speed_scale) - 1; }

// Whether the rear wheels' measured s contradicts `predicted` (why in `why`).
bool WheelsContradict(const WheelYawFacts& w, double predicted, std::string& why) {
  if (!w.available || !(w.sd > 0) || std::abs(w.scale - predicted) <= kWheelEvidenceZ * w.sd) return false;
  why = Fmt("the rear wheels give the gyro %+.2f +- %.2f %% against the %+.2f %% it implies", 100 * w.scale, 100 * w.sd,
            100 * predicted);
  return true;
}

WheelYawFacts WheelEvidence(const std::vector<const stats::Segment*>& window, double track_rear_m) {
  WheelYawFacts w;
  if (!(track_rear_m > 0)) return w;
  const stats::WheelYawEvidence ev = stats::EstimateWheelYawScale(window, track_rear_m);
  w.available = ev.available;
  w.scale = ev.scale;
  w.sd = ev.prior_sd;
  w.note = ev.note;
  return w;
}

// The rear wheels' verdicts: on every alternative, and on the fit as identified (whose scales
// imply `own`); the standing alternative with the lowest held-out a_y RMSE published in the
// fit's place when it is ruled out.
void RefereeByWheels(double own, double track_rear_m, ModelChoice& choice) {
  if (!choice.wheel_yaw.available) return;
  for (ModelAlternative& a : choice.alternatives) {
    if (a.ruled_out) continue;
    const double predicted = a.configured && a.result
                                 ? PredictedWheelScale(EffectValue(*a.result, "gyro_scale"), EffectValue(*a.result, "speed_scale"))
                             : a.name.starts_with("gyro_scale") ? PredictedWheelScale(a.scale, 0)
                             : a.name == "speed_scale"          ? PredictedWheelScale(0, a.scale)
                                                                : 0.0;
    a.ruled_out = WheelsContradict(choice.wheel_yaw, predicted, a.ruled_out_why);
  }
  if (!WheelsContradict(choice.wheel_yaw, own, choice.fit_ruled_out_why)) return;
  const ModelAlternative* best = nullptr;
  for (const ModelAlternative& a : choice.alternatives)
    if (!a.ruled_out && a.result && (!best || a.rmse_a_y_mps2 < best->rmse_a_y_mps2)) best = &a;
  if (best) {
    choice.published = best->name;
    return;
  }
  // Nothing stands: with the gyro and the speed right, the wheels measure the track instead.
  choice.notes.push_back(Fmt("with the gyro's and the speed's scales right, the rear wheels put the rear track at %.3f m "
                             "(vehicle.track_rear_m %.3f m)",
                             track_rear_m / (1 + choice.wheel_yaw.scale), track_rear_m));
}

}  // namespace

bool ScaleDisagreement(const identify::IdentificationResult& fit, const adequacy::PlausibilityReport& data_checks,
                       double* gain, double* gain_se) {
  if (!fit.valid || !fit.yaw_rate_output) return false;
  const adequacy::Check* k = Kinematics(data_checks);
  if (!k || k->verdict != adequacy::Verdict::kPassed || !(k->value_se > 0) || !(k->value > 0)) return false;
  const double d = std::abs(k->value - 1);
  if (gain) *gain = k->value;
  if (gain_se) *gain_se = k->value_se;
  return d > kSignificanceZ * k->value_se && d > kMinScaleDisagreement;
}

namespace {

// The scale attributions (above) when the kinematics or the rear wheels show a disagreement.
void FitScaleAttributions(const identify::Identifier& identifier, const WindowSnapshot& snap,
                          const identify::IdentificationResult& fit, const adequacy::PlausibilityReport& data_checks,
                          double own, ModelChoice& choice) {
  const bool kinematics = ScaleDisagreement(fit, data_checks, &choice.gain, &choice.gain_se);
  const WheelYawFacts& wheels = choice.wheel_yaw;
  const bool wheels_disagree = wheels.available && std::abs(wheels.scale - own) > kSignificanceZ * wheels.sd &&
                               std::abs(wheels.scale - own) > kMinScaleDisagreement;
  if (!kinematics && !wheels_disagree) return;
  choice.judged = true;
  // Starts: where the kinematic gain puts each scale; the gyro's where the rear wheels do.
  const double g = choice.gain > 0 ? choice.gain : 1.0;
  const double s = wheels.available ? wheels.scale : 1 / g - 1;
  const struct {
    const char* effect;
    double value;
  } attributions[] = {{"accel_scale", g - 1}, {"gyro_scale", s}, {"speed_scale", kinematics ? 1 / g - 1 : 1 / (1 + s) - 1}};
  for (const auto& a : attributions) {
    if (!identifier.spec().library().Find(a.effect)) {
      choice.notes.push_back(std::string(a.effect) + " left out: not an effect of the library");
      continue;
    }
    std::string why;
    if (std::string(a.effect) == "speed_scale" && SpeedScaleDecided(snap.AllSegments(), a.value, why)) {
      choice.notes.push_back(why);
      continue;
    }
    std::optional<config::ParameterPrior> prior;
    if (std::string(a.effect) == "gyro_scale" && wheels.available)
      prior = config::ParameterPrior{.name = "gyro_scale", .value = wheels.scale, .sd = wheels.sd, .location = "rear wheels"};
    ModelAlternative alt = Refit(identifier, snap, fit, a.effect, a.value, prior);
    JudgeAgainstFit(fit, alt);
    choice.alternatives.push_back(std::move(alt));
    if (prior) {  // the gyro's scale held where the wheels put it: the spread covers the two references' disagreement
      ModelAlternative at = Refit(identifier, snap, fit, a.effect, wheels.scale, std::nullopt, true);
      JudgeAgainstFit(fit, at);
      choice.alternatives.push_back(std::move(at));
    }
  }
}

// A watched effect refitted as an alternative, `evidence` the score test that found it.
void RefitWatched(const identify::Identifier& identifier, const WindowSnapshot& snap, const identify::IdentificationResult& fit,
                  const std::string& effect, const std::string& evidence, ModelChoice& choice) {
  ModelAlternative alt = Refit(identifier, snap, fit, effect, std::nullopt, std::nullopt);
  alt.evidence = evidence;
  JudgeAgainstFit(fit, alt);
  choice.alternatives.push_back(std::move(alt));
  choice.judged = true;
}

// The watched effects' score tests at the fit (training drives), each significant one refitted;
// or, at an incremental update (watch.test false), the last test's findings carried.
void FitWatched(const identify::Identifier& identifier, const WindowSnapshot& snap, const identify::IdentificationResult& fit,
                const WatchRequest& watch, const std::vector<std::string>& configured, ModelChoice& choice) {
  const std::vector<std::string> names = WatchedToTest(watch.effects, identifier.spec(), configured);
  if (!watch.test) {  // an incremental update: what the last test found, its EG shift carried
    for (const WatchFinding& f : watch.found) {
      if (std::find(names.begin(), names.end(), f.alternative.name) == names.end()) continue;
      ModelAlternative alt = f.alternative;
      alt.evidence += Fmt(" (at the last full-window or exact fit; its EG shift %+.3f deg/g carried, not refitted)", f.eg_shift_deg_per_g);
      alt.eg_deg_per_g = fit.eg_deg_per_g + f.eg_shift_deg_per_g;
      choice.alternatives.push_back(std::move(alt));
      choice.judged = true;
    }
    return;
  }
  choice.watch_tested = true;
  if (names.empty() || snap.training.empty()) return;
  discover::DiagnosisOptions options;
  options.candidates = names;
  options.z_threshold = kSignificanceZ;
  discover::Diagnosis d;
  try {
    d = discover::Diagnose(identifier, fit.AllValues(), snap.training, options);
  } catch (const std::exception& e) {  // out of memory, a formula that cannot be evaluated
    choice.notes.push_back("model.watch not tested: " + std::string(e.what()));
    return;
  }
  for (const discover::CandidateScore& s : d.ranked) {
    if (s.significant)
      RefitWatched(identifier, snap, fit, s.effect, Fmt("score test at the fit: z %+.1f, one-step %.4g", s.z_robust, s.one_step), choice);
  }
}

// names[i] of the list under `key`: a library or formula effect, not listed before it. Throws
// ConfigError "key: 'name' ...".
void CheckListedEffect(const std::vector<std::string>& names, size_t i, const std::string& key, const model::EffectLibrary& library) {
  const std::string& n = names[i];
  const std::string where = key + ": '" + n + "'";
  if (!library.Find(n)) throw ConfigError(where + " is not an effect of the library or a formula (model.formulas)");
  if (std::find(names.begin(), names.begin() + static_cast<long>(i), n) != names.begin() + static_cast<long>(i))
    throw ConfigError(where + " is listed twice");
}

}  // namespace

ModelChoice FitModelAlternatives(const identify::Identifier& identifier, const WindowSnapshot& snap,
                                 const identify::IdentificationResult& fit, const adequacy::PlausibilityReport& data_checks,
                                 double track_rear_m, const std::vector<std::string>& configured,
                                 const WatchRequest& watch) {
  ModelChoice choice;
  if (!fit.valid) return choice;
  const auto t0 = std::chrono::steady_clock::now();
  choice.wheel_yaw = WheelEvidence(snap.AllSegments(), track_rear_m);
  const double own = PredictedWheelScale(EffectValue(fit, "gyro_scale"), EffectValue(fit, "speed_scale"));
  if (fit.yaw_rate_output) FitScaleAttributions(identifier, snap, fit, data_checks, own, choice);
  for (const std::string& name : configured) {
    ModelAlternative alt = Refit(identifier, snap, fit, name, std::nullopt, std::nullopt);
    JudgeAgainstFit(fit, alt);
    choice.alternatives.push_back(std::move(alt));
    choice.judged = true;
  }
  FitWatched(identifier, snap, fit, watch, configured, choice);
  if (!choice.judged) return ModelChoice{.watch_tested = choice.watch_tested};
  RefereeByWheels(own, track_rear_m, choice);
  choice.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return choice;
}

std::vector<WatchFinding> WatchFound(const ModelChoice& choice, double fit_eg_deg_per_g) {
  std::vector<WatchFinding> found;
  for (const ModelAlternative& a : choice.alternatives) {
    if (a.evidence.empty() || a.ruled_out || !a.fitted) continue;
    WatchFinding f{.alternative = a, .eg_shift_deg_per_g = a.eg_deg_per_g - fit_eg_deg_per_g};
    f.alternative.result.reset();
    found.push_back(std::move(f));
  }
  return found;
}

void CheckWatched(const std::vector<std::string>& watched, const model::EffectLibrary& library) {
  for (size_t i = 0; i < watched.size(); ++i) CheckListedEffect(watched, i, "model.watch", library);
}

std::vector<std::string> WatchedToTest(const std::vector<std::string>& watched, const model::ModelSpec& spec,
                                       const std::vector<std::string>& configured) {
  std::vector<std::string> out;
  const std::vector<std::string> effects = spec.effect_names();
  for (const std::string& w : watched) {
    if (std::find(effects.begin(), effects.end(), w) != effects.end() ||
        std::find(configured.begin(), configured.end(), w) != configured.end())
      continue;
    std::vector<std::string> with = effects;
    with.push_back(w);
    try {
      (void)model::ModelSpec::FromNames(with, spec.library());
    } catch (const ConfigError&) {
      continue;  // shares a parameter with the model's effects (an alternative form of one of them)
    }
    out.push_back(w);
  }
  return out;
}

void CheckAlternatives(const std::vector<std::string>& alternatives, const std::vector<std::string>& effects,
                       const model::EffectLibrary& library) {
  for (size_t i = 0; i < alternatives.size(); ++i) {
    const std::string& a = alternatives[i];
    const std::string where = "model.alternatives: '" + a + "'";
    CheckListedEffect(alternatives, i, "model.alternatives", library);
    if (std::find(effects.begin(), effects.end(), a) != effects.end())
      throw ConfigError(where + " is in model.effects already (an alternative is refitted added to the model)");
    std::vector<std::string> with = effects;
    with.push_back(a);
    try {
      (void)model::ModelSpec::FromNames(with, library);
    } catch (const ConfigError& e) {
      throw ConfigError(where + " cannot be added to model.effects: " + e.what());
    }
  }
}

}  // namespace ndsid::pipeline
