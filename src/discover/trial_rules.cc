#include "trial_rules.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include <Eigen/Dense>

namespace ndsid::discover {

double HeldOutRmse(const identify::IdentificationResult& fit) {
  return fit.rmse_validation_mps2 >= 0 ? fit.rmse_validation_mps2 : fit.rmse_train_mps2;
}

double HeldOutYawRmse(const identify::IdentificationResult& fit) {
  return fit.rmse_validation_yaw_radps >= 0 ? fit.rmse_validation_yaw_radps : fit.rmse_train_yaw_radps;
}

bool BothOutputsScored(const identify::IdentificationResult& before, const identify::IdentificationResult& after) {
  return before.yaw_rate_output && after.yaw_rate_output && before.rmse_train_yaw_radps > 0 && after.rmse_train_yaw_radps > 0;
}

namespace {

// The integrated autocorrelation time of residuals with noise level sigma^2 tau and RMSE sigma
// (at least 1).
double AutocorrelationTime(double noise_level, double rmse) {
  const double t = rmse > 0 ? noise_level / (rmse * rmse) : 0.0;
  return std::isfinite(t) && t >= 1.0 ? t : 1.0;
}

}  // namespace

BicChange DeltaBic(const identify::IdentificationResult& before, const identify::IdentificationResult& after, bool both) {
  const auto& fit = before;
  const auto& f2 = after;
  BicChange b;
  const double n_eff = static_cast<double>(f2.residuals_train) / AutocorrelationTime(f2.noise_level_a_y, f2.rmse_train_mps2);
  const double n_eff_r =
      both ? static_cast<double>(f2.residuals_train_yaw) / AutocorrelationTime(f2.noise_level_yaw_rate, f2.rmse_train_yaw_radps)
           : 0.0;
  double dbic = n_eff * std::log((f2.rmse_train_mps2 * f2.rmse_train_mps2) / (fit.rmse_train_mps2 * fit.rmse_train_mps2)) +
                (static_cast<double>(f2.NumEstimated()) - static_cast<double>(fit.NumEstimated())) * std::log(std::max(n_eff + n_eff_r, 2.0));
  if (both) dbic += n_eff_r * std::log((f2.rmse_train_yaw_radps * f2.rmse_train_yaw_radps) / (fit.rmse_train_yaw_radps * fit.rmse_train_yaw_radps));
  b.delta = dbic;
  b.n_eff = n_eff;
  return b;
}

bool HeldOutImproves(double before, double after, double yaw_before, double yaw_after, bool both,
                     double min_relative_improvement) {
  const bool a_y_falls = after < before * (1.0 - min_relative_improvement);
  if (!both) return a_y_falls;
  return (a_y_falls && yaw_after < 1.01 * yaw_before) ||
         (yaw_after < yaw_before * (1.0 - min_relative_improvement) && after < 1.01 * before);
}

std::string PriorContradiction(const identify::IdentificationResult& before, const identify::IdentificationResult& after,
                               const std::vector<config::ParameterPrior>& priors) {
  std::string contradicts;
  for (const identify::ParameterEstimate& p : after.effect_params) {
    for (const config::ParameterPrior& pr : priors) {
      if (pr.name != p.name || !(pr.sd > 0) || std::abs(p.value - pr.value) <= 3 * pr.sd) continue;
      bool before_too = false;  // only the parameters the candidate adds
      for (const identify::ParameterEstimate& q : before.effect_params) before_too = before_too || q.name == p.name;
      if (before_too) continue;
      char buf[200];
      std::snprintf(buf, sizeof buf, "%s = %.4g lies %.1f prior sd from its prior %.4g +- %.2g (%s)", p.name.c_str(), p.value,
                    std::abs(p.value - pr.value) / pr.sd, pr.value, pr.sd, pr.location.c_str());
      contradicts = buf;
    }
  }
  return contradicts;
}

void RecordEgShift(Trial& t, const identify::IdentificationResult& before, const identify::IdentificationResult& after) {
  const auto& fit = before;
  const auto& f2 = after;
  t.eg_shift_rel = fit.eg_rad_per_mps2 != 0 ? (f2.eg_rad_per_mps2 - fit.eg_rad_per_mps2) / std::abs(fit.eg_rad_per_mps2) : 0.0;
  t.eg_shift_sigma = f2.eg_se_rad_per_mps2 > 0 ? (f2.eg_rad_per_mps2 - fit.eg_rad_per_mps2) / f2.eg_se_rad_per_mps2 : 0.0;
}

void RecordRefit(Trial& t, const identify::IdentificationResult& before, const identify::IdentificationResult& after, bool both) {
  t.held_out_after = HeldOutRmse(after);
  if (both) t.yaw_before = HeldOutYawRmse(before), t.yaw_after = HeldOutYawRmse(after);
  RecordEgShift(t, before, after);
}

std::string HeldOutChangeText(const Trial& t, bool both) {
  char text[80];
  int n = std::snprintf(text, sizeof text, "held-out RMSE %+.1f %%", 100 * (t.held_out_after / t.held_out_before - 1));
  if (both) std::snprintf(text + n, sizeof text - n, ", yaw rate %+.1f %%", 100 * (t.yaw_after / t.yaw_before - 1));
  return text;
}

bool IsEgRelevant(const Trial& t, const LadderOptions& options) {
  const double before = t.held_out_before, after = t.held_out_after, yb = t.yaw_before, ya = t.yaw_after;
  const double fall = std::max(1.0 - after / before, 1.0 - ya / yb);
  return after <= before && ya <= yb && fall >= options.eg_relevant_min_improvement && t.delta_bic < 0 &&
         std::abs(t.eg_shift_sigma) > options.eg_relevant_shift_sigma && std::abs(t.eg_shift_rel) > options.eg_relevant_shift_rel;
}

double ComparableYawRmse(const identify::IdentificationResult& fit, double yaw_noise_sd, double yaw_shift_samples) {
  const double w = yaw_shift_samples - std::floor(yaw_shift_samples);
  const double left = (1 - w) * (1 - w) + w * w;  // share of the white noise's variance a read at w keeps
  const double rmse = HeldOutYawRmse(fit);
  return std::sqrt(rmse * rmse + (1 - left) * yaw_noise_sd * yaw_noise_sd);
}

double HeldOutChange(const identify::IdentificationResult& before, const identify::IdentificationResult& after,
                     double yaw_after) {
  double sum = HeldOutRmse(after) / HeldOutRmse(before) - 1;
  if (BothOutputsScored(before, after)) sum += yaw_after / HeldOutYawRmse(before) - 1;
  return sum;
}

std::string AlignmentRejection(const identify::IdentificationResult& recorded, const identify::IdentificationResult& aligned,
                               double yaw_aligned, double training_margin) {
  constexpr double kNoise = 0.002;  // relative: the samples trimmed at the segments' ends
  const double ay = HeldOutRmse(aligned) / HeldOutRmse(recorded) - 1;
  const bool both = BothOutputsScored(recorded, aligned);
  const double yaw = both ? yaw_aligned / HeldOutYawRmse(recorded) - 1 : 0.0;
  const bool training_only = recorded.rmse_validation_mps2 < 0 || aligned.rmse_validation_mps2 < 0;
  const bool margin_met = HeldOutImproves(1.0, 1.0 + ay, 1.0, 1.0 + yaw, both, training_margin);
  if (!(ay > kNoise || yaw > kNoise || ay + yaw >= 0) && (!training_only || margin_met)) return "";
  char buf[200];
  if (training_only) {
    std::snprintf(buf, sizeof buf, "no drive held out: on the training data the shifts must lower an output's RMSE by %.0f %% "
                  "(an effect's margin): a_y %+.1f %%", 100 * training_margin, 100 * ay);
  } else {
    std::snprintf(buf, sizeof buf, "the shifts raise a held-out RMSE or lower none: a_y %+.1f %%", 100 * ay);
  }
  std::string why = buf;
  if (both) {
    std::snprintf(buf, sizeof buf, ", yaw rate %+.1f %% (its noise as read at whole samples)", 100 * yaw);
    why += buf;
  }
  return why;
}

std::string ImplausibleParameters(const model::Effect& effect, const identify::IdentificationResult& fit, double z) {
  const std::string undetermined = UndeterminedParameters(effect, fit, z);
  const std::string on_bound = ParametersOnTheirBounds(effect, fit);
  return undetermined + (undetermined.empty() || on_bound.empty() ? "" : ", ") + on_bound;
}

bool HeldOutHolds(const Trial& t, bool both) {
  return t.held_out_after <= 1.01 * t.held_out_before && (!both || t.yaw_after <= 1.01 * t.yaw_before);
}

double ChiSquareQuantileAtZ(int k, double z) {
  if (k <= 1) return z * z;
  const double tail = std::erfc(z / std::sqrt(2.0));  // two-sided
  double lo = 0, hi = 40;  // the one-sided normal quantile with that tail, by bisection
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > tail ? lo : hi) = mid;
  }
  const double c = 2.0 / (9.0 * k), z1 = 0.5 * (lo + hi);
  return k * std::pow(1.0 - c + z1 * std::sqrt(c), 3);
}

namespace {

// The joint rule for several parameters (above): "" when their Wald statistic exceeds the
// quantile, else why not; nullopt when the fit's correlations do not cover them.
std::optional<std::string> JointlyUndetermined(const std::vector<std::pair<const model::EffectParam*, size_t>>& judged,
                                               const identify::IdentificationResult& fit, double z) {
  const size_t np = model::kNumParams + fit.effect_params.size(), k = judged.size();
  if (fit.correlation.size() != np * np) return std::nullopt;
  Eigen::VectorXd d(k);
  Eigen::MatrixXd r(k, k);
  std::string names;
  for (size_t a = 0; a < k; ++a) {
    const identify::ParameterEstimate& e = fit.effect_params[judged[a].second];
    if (!(e.se > 0)) return std::nullopt;
    d(a) = (e.value - judged[a].first->neutral) / e.se;
    for (size_t b = 0; b < k; ++b)
      r(a, b) = fit.correlation[(model::kNumParams + judged[a].second) * np + model::kNumParams + judged[b].second];
    names += (a ? ", " : "") + judged[a].first->name;
  }
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(r);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return std::nullopt;
  const double w = d.dot(ldlt.solve(d)), q = ChiSquareQuantileAtZ(static_cast<int>(k), z);
  if (std::isfinite(w) && w > q) return std::string();
  char buf[240];
  std::snprintf(buf, sizeof buf, "%s are jointly within %.0f sigma of their neutral values (Wald chi-square %.1f, needs > %.1f for %zu; "
                "not determined)", names.c_str(), z, w, q, k);
  return std::string(buf);
}

}  // namespace

std::string UndeterminedParameters(const model::Effect& effect, const identify::IdentificationResult& fit, double z) {
  std::vector<std::pair<const model::EffectParam*, size_t>> judged;  // the parameter, its index in effect_params
  for (const model::EffectParam& p : effect.info().params) {
    if (p.per_drive) continue;
    const auto e = std::find_if(fit.effect_params.begin(), fit.effect_params.end(),
                                [&](const identify::ParameterEstimate& x) { return x.name == p.name; });
    if (e == fit.effect_params.end() || e->fixed) continue;
    judged.emplace_back(&p, static_cast<size_t>(e - fit.effect_params.begin()));
  }
  if (judged.size() >= 2) {
    if (const std::optional<std::string> joint = JointlyUndetermined(judged, fit, z)) return *joint;
  }
  std::string out;
  for (const auto& [pp, i] : judged) {
    const model::EffectParam& p = *pp;
    const identify::ParameterEstimate* e = &fit.effect_params[i];
    if (std::abs(e->value - p.neutral) > z * e->se) continue;
    char buf[200];
    std::snprintf(buf, sizeof buf, "%s = %.4g +- %.2g %s is within %.0f sigma of %.4g (not determined)", p.name.c_str(), e->value,
                  e->se, e->unit.c_str(), z, p.neutral);
    out += (out.empty() ? "" : ", ") + std::string(buf);
  }
  return out;
}

std::string ParametersOnTheirBounds(const model::Effect& effect, const identify::IdentificationResult& fit) {
  std::string out;
  for (const model::EffectParam& p : effect.info().params) {
    if (p.per_drive) continue;
    const auto e = std::find_if(fit.effect_params.begin(), fit.effect_params.end(),
                                [&](const identify::ParameterEstimate& x) { return x.name == p.name; });
    if (e == fit.effect_params.end() || e->fixed || !e->at_bound) continue;
    char buf[200];
    std::snprintf(buf, sizeof buf, "%s = %.4g %s is on its bound [%.4g, %.4g] (not physically plausible)", p.name.c_str(),
                  e->value, e->unit.c_str(), p.lower, p.upper);
    out += (out.empty() ? "" : ", ") + std::string(buf);
  }
  return out;
}

}  // namespace ndsid::discover
