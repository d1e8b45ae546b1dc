#include "ndsid/pipeline/model_choice.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "ndsid/common/format.h"
#include "ndsid/pipeline/pipeline.h"
#include "ndsid/stats/speed_scale.h"

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
bool SpeedScaleDecided(const WindowSnapshot& snap, double eps, std::string& why) {
  std::vector<const stats::Segment*> all(snap.training.begin(), snap.training.end());
  all.insert(all.end(), snap.validation.begin(), snap.validation.end());
  const stats::SpeedScaleEvidence ev = stats::EstimateSpeedScale(all);
  if (!ev.available || !(ev.prior_sd > 0)) return false;
  const bool zero = std::abs(ev.scale) <= kSpeedEvidenceZ * ev.prior_sd;
  const bool excludes = std::abs(ev.scale - eps) > kSpeedEvidenceZ * ev.prior_sd;
  if (!(zero && excludes)) return false;
  why = Fmt("speed_scale left out: a_x against dv/dt gives %+.2f +- %.2f %%, consistent with 0 and not %+.2f %%",
            100 * ev.scale, 100 * ev.prior_sd, 100 * eps);
  return true;
}

// One refit of the window with `effect`'s scale (added to the model when it lacks it) free, started
// at the attribution `value`; the scale the fit ends on is the alternative's.
ModelAlternative Refit(const identify::Identifier& identifier, const WindowSnapshot& snap,
                       const identify::IdentificationResult& fit, const std::string& effect, double value) {
  ModelAlternative alt{.name = effect, .scale = value};
  const model::ModelSpec& spec = identifier.spec();
  std::vector<std::string> names = spec.effect_names();
  if (std::find(names.begin(), names.end(), effect) == names.end()) names.push_back(effect);
  const config::IdentificationConfig& cfg = identifier.config();
  try {
    const model::ModelSpec alt_spec = model::ModelSpec::FromNames(names, spec.library());
    identify::Identifier id(cfg, identifier.wheelbase_m(), alt_spec);
    id.set_standstill(snap.standstill);
    id.set_drive_values(fit.drive_values);
    std::vector<double> start = fit.ValuesFor(alt_spec);
    const int k = alt_spec.param_index(effect);
    if (k >= 0 && k < static_cast<int>(start.size())) start[k] = value;
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

ModelChoice FitModelAlternatives(const identify::Identifier& identifier, const WindowSnapshot& snap,
                                 const identify::IdentificationResult& fit, const adequacy::PlausibilityReport& data_checks) {
  ModelChoice choice;
  if (!ScaleDisagreement(fit, data_checks, &choice.gain, &choice.gain_se)) return choice;
  const auto t0 = std::chrono::steady_clock::now();
  choice.judged = true;
  const double g = choice.gain;
  const struct {
    const char* effect;
    double value;
  } attributions[] = {{"accel_scale", g - 1}, {"gyro_scale", 1 / g - 1}, {"speed_scale", 1 / g - 1}};
  for (const auto& a : attributions) {
    if (!identifier.spec().library().Find(a.effect)) {
      choice.notes.push_back(std::string(a.effect) + " left out: not an effect of the library");
      continue;
    }
    std::string why;
    if (std::string(a.effect) == "speed_scale" && SpeedScaleDecided(snap, a.value, why)) {
      choice.notes.push_back(why);
      continue;
    }
    ModelAlternative alt = Refit(identifier, snap, fit, a.effect, a.value);
    JudgeAgainstFit(fit, alt);
    choice.alternatives.push_back(std::move(alt));
  }
  choice.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return choice;
}

}  // namespace ndsid::pipeline
