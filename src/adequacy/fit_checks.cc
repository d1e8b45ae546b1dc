#include "ndsid/adequacy/fit_checks.h"
#include "ndsid/common/format.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>

namespace ndsid::adequacy {
namespace {

Check Converged(const FitFacts& f) {
  Check c{.name = "converged"};
  c.value = f.iterations;
  if (f.termination.empty()) {
    c.message = "solver: skipped (no fit)";
    return c;
  }
  c.verdict = f.termination == "CONVERGENCE" ? Verdict::kPassed : Verdict::kFailed;
  c.message = Fmt("solver ended %s after %d iterations", f.termination.c_str(), f.iterations);
  if (f.termination == "NO_CONVERGENCE")
    c.message += ": it stopped at its iteration cap, not at an optimum (identification.max_iterations, or a model the data cannot settle)";
  else if (c.verdict == Verdict::kFailed)
    c.message += ": the estimate is not an optimum of the fit";
  return c;
}

Check Explained(const OutputFacts& o, const config::PlausibilityConfig& q) {
  Check c{.name = "explained_" + o.output};
  if (!(o.rmse >= 0) || o.residuals == 0) {
    c.message = o.output + " explained: skipped (no residuals)";
    return c;
  }
  const double to_floor = o.floor > 0 ? o.rmse / o.floor : INFINITY;
  const double to_spread = o.spread > 0 ? o.rmse / o.spread : INFINITY;
  c.value = to_floor;
  // Below the negligible share of the spread the floor does not judge (noise-free data).
  const bool negligible = to_spread <= q.rmse_negligible_spread_ratio;
  const bool floor_ok = to_floor <= q.rmse_floor_ratio_max || negligible;
  const bool spread_ok = to_spread <= q.rmse_spread_ratio_max;
  c.verdict = floor_ok && spread_ok ? Verdict::kPassed : Verdict::kFailed;
  c.message = Fmt("%s RMSE %.3g %s = %.2f x its noise floor %.3g (accepted <= %.2g) and %.2f of its spread %.3g about zero "
                  "(accepted <= %.2g)", o.output.c_str(), o.rmse, o.unit.c_str(), to_floor, o.floor, q.rmse_floor_ratio_max,
                  to_spread, o.spread, q.rmse_spread_ratio_max);
  if (negligible && to_floor > q.rmse_floor_ratio_max)
    c.message += Fmt(": within %.2g of its spread, negligible whatever the floor (noise-free or filtered data)",
                     q.rmse_negligible_spread_ratio);
  if (!spread_ok)
    c.message += ": the model does not follow the signal (a wrong signal, sign or unit, or a fit that failed)";
  else if (!floor_ok)
    c.message += ": the residual keeps structure the model lacks (an effect outside the model, a time skew, a sensor "
                 "error: ndsid diagnose names candidates)";
  return c;
}

Check Bounds(const FitFacts& f, const config::PlausibilityConfig& q) {
  Check c{.name = "bounds"};
  if (f.at_bound.empty()) {
    c.verdict = Verdict::kPassed;
    c.message = "no parameter ended on its bound";
    return c;
  }
  std::string list;
  for (const BoundFacts& b : f.at_bound)
    list += Fmt("%s%s = %.4g (EG %+.3f deg/g if released, corr. %+.2f)", list.empty() ? "" : ", ", b.name.c_str(), b.value,
                b.eg_shift_deg_per_g, b.eg_correlation);
  const double s = f.eg_se_deg_per_g > 0 ? f.eg_bound_shift_deg_per_g / f.eg_se_deg_per_g : INFINITY;
  c.value = s;
  c.verdict = std::abs(s) <= q.bound_shift_sigma_max ? Verdict::kPassed : Verdict::kFailed;
  c.message = Fmt("released, the bounds would move EG by %+.3f deg/g = %+.2f sigma (accepted <= %.2g): ", f.eg_bound_shift_deg_per_g, s,
                  q.bound_shift_sigma_max) +
              list;
  if (c.verdict == Verdict::kFailed)
    c.message += ": the box, not the data, sets EG (widen identification.parameters, or check the vehicle data)";
  return c;
}

Check SteadyState(const FitFacts& f, const config::PlausibilityConfig& q) {
  Check c{.name = "steady_state"};
  if (!f.steady_state_valid) {
    c.message = "dynamic EG against the steady-state EG: skipped (no steady-state estimate)";
    return c;
  }
  const double d = f.eg_deg_per_g - f.steady_state_eg_deg_per_g;
  const double bias = q.steady_state_rel_bias * std::abs(f.steady_state_eg_deg_per_g);
  const double s = std::sqrt(f.eg_se_deg_per_g * f.eg_se_deg_per_g +
                             f.steady_state_eg_se_deg_per_g * f.steady_state_eg_se_deg_per_g + bias * bias);
  c.value = s > 0 ? d / s : INFINITY;
  c.verdict = std::abs(c.value) <= q.steady_state_z_max ? Verdict::kPassed : Verdict::kFailed;
  c.message = Fmt("dynamic EG %.2f +- %.2f against steady-state %.2f +- %.2f deg/g: %+.2f sigma (with %.0f %% for the "
                  "regression's bias; accepted <= %.1f)", f.eg_deg_per_g, f.eg_se_deg_per_g, f.steady_state_eg_deg_per_g,
                  f.steady_state_eg_se_deg_per_g, c.value, 100 * q.steady_state_rel_bias, q.steady_state_z_max);
  if (c.verdict == Verdict::kFailed)
    c.message += ": the two estimates of one car disagree (a model the data contradict, parameters on their bounds, "
                 "or an effect both read differently)";
  return c;
}

Check Halves(const FitFacts& f, const config::PlausibilityConfig& q) {
  Check c{.name = "halves"};
  if (!f.halves) {
    c.message = Fmt("EG of two halves of the window: skipped (%d drive%s; needs 2, or one whose chunks split into two halves "
                    "of %zu)", f.window_drives, f.window_drives == 1 ? "" : "s", f.halves_min_chunks);
    return c;
  }
  const HalfFacts& a = f.halves->first;
  const HalfFacts& b = f.halves->second;
  const std::string how = a.in_time ? Fmt("the one drive's earlier and later gated time, %zu and %zu chunks", a.chunks, b.chunks)
                                    : Fmt("alternate drives, %d and %d", a.drives, b.drives);
  if (!a.valid || !b.valid) {
    c.verdict = Verdict::kFailed;
    c.message = "EG of two halves of the window (" + how + "): a half's fit is not valid (" + (a.valid ? b.reason : a.reason) + ")";
    return c;
  }
  const double d = a.eg_deg_per_g - b.eg_deg_per_g;
  const double s = std::hypot(a.eg_se_deg_per_g, b.eg_se_deg_per_g);
  c.value = s > 0 ? d / s : INFINITY;
  c.verdict = std::abs(c.value) <= q.halves_z_max ? Verdict::kPassed : Verdict::kFailed;
  c.message = Fmt("EG of two halves (%s): %.2f +- %.2f and %.2f +- %.2f deg/g, %+.2f combined sigma (accepted <= %.1f)",
                  how.c_str(), a.eg_deg_per_g, a.eg_se_deg_per_g, b.eg_deg_per_g, b.eg_se_deg_per_g, c.value, q.halves_z_max);
  if (c.verdict == Verdict::kFailed)
    c.message += a.in_time ? ": EG depends on which part of the drive is fitted (its sigma is too small for the data, or the car "
                             "or the road changed during the drive)"
                           : ": EG depends on which drives are fitted (its sigma is too small for the data, or the drives differ)";
  return c;
}

Check ModelChoice(const FitFacts& f, const config::PlausibilityConfig& q) {
  Check c{.name = "model_choice"};
  const ModelChoiceFacts& m = *f.model_choice;
  std::string each, configured, watched;
  for (const AlternativeFacts& a : m.alternatives) {
    std::string& list = !a.evidence.empty() ? watched : a.configured ? configured : each;
    list += (list.empty() ? "" : "; ") +
            (a.configured ? Fmt("+%s (%s %.4g)", a.name.c_str(), a.parameter.c_str(), a.scale)
                          : Fmt("%s %+.2f %%", a.name.c_str(), 100 * a.scale)) + ": ";
    if (!a.evidence.empty()) list += a.evidence + "; ";
    list += a.ruled_out ? "ruled out (" + a.ruled_out_why + ")" : Fmt("EG %.3f +- %.3f", a.eg_deg_per_g, a.eg_se_deg_per_g);
  }
  for (const std::string& n : m.notes) each += (each.empty() ? "" : "; ") + n;
  const double spread = ModelChoiceSpread(f.eg_deg_per_g, m);
  const double widened = WidenedSigma(m.eg_se_published_deg_per_g, spread);
  const double scale = std::max(std::abs(f.eg_deg_per_g), q.eg_se_floor_deg_per_g);
  c.value = spread / scale;
  const bool orphaned = !m.fit_ruled_out_why.empty() && m.published.empty();
  c.verdict = c.value <= q.model_choice_spread_rel_max && !orphaned ? Verdict::kPassed : Verdict::kFailed;
  c.message = m.gain > 0 ? Fmt("a_y against v*r gain %.4f +- %.4f", m.gain, m.gain_se) : std::string("a_y against v*r agree");
  if (!m.wheel_note.empty()) c.message += "; " + m.wheel_note;
  if (!each.empty()) c.message += ": refitted with the disagreement in each sensor (" + each + ")";
  if (!configured.empty()) c.message += ": refitted with each of model.alternatives (" + configured + ")";
  if (!watched.empty()) c.message += ": refitted with each effect of model.watch its score test finds missing (" + watched + ")";
  c.message += Fmt(": EG spread %.3f deg/g = %.1f %% of |EG| (accepted <= %.0f %%), sigma(EG) widened %.3f -> %.3f deg/g", spread,
                   100 * c.value, 100 * q.model_choice_spread_rel_max, m.eg_se_published_deg_per_g, widened);
  if (!m.fit_ruled_out_why.empty())
    c.message += "; the fit as identified ruled out (" + m.fit_ruled_out_why + ")" +
                 (m.published.empty() ? ": no attribution stands" : ": the " + m.published + " refit is published");
  if (c.verdict == Verdict::kFailed)
    c.message += orphaned ? ": the rear wheels contradict every model fitted (the track width, the wheel-speed role or slip?)"
                          : each.empty() ? ": EG depends on which of the models is right, and the data do not say (a prior on "
                                           "the effect, model.priors, or more varied driving decides it)"
                                         : ": EG depends on which sensor's scale is off, and the bus does not say (a second yaw or "
                                           "speed reference decides it)";
  return c;
}

}  // namespace

double ModelChoiceSpread(double eg_deg_per_g, const ModelChoiceFacts& m) {
  double lo = eg_deg_per_g, hi = eg_deg_per_g;
  for (const AlternativeFacts& a : m.alternatives) {
    if (a.ruled_out) continue;
    lo = std::min(lo, a.eg_deg_per_g);
    hi = std::max(hi, a.eg_deg_per_g);
  }
  return hi - lo;
}

double WidenedSigma(double eg_se_deg_per_g, double spread_deg_per_g) {
  return std::hypot(eg_se_deg_per_g, spread_deg_per_g);
}

double FloorFromSums(double s0, double s1, double n) {
  if (!(n > 0)) return -1;
  return std::sqrt(std::max(0.0, s0 - s1) / n);
}

void CheckFit(const FitFacts& f, const config::PlausibilityConfig& q, PlausibilityReport& report) {
  report.checks.push_back(Converged(f));
  for (const OutputFacts& o : f.outputs) report.checks.push_back(Explained(o, q));
  report.checks.push_back(Bounds(f, q));
  report.checks.push_back(SteadyState(f, q));
  report.checks.push_back(Halves(f, q));
  if (f.model_choice) report.checks.push_back(ModelChoice(f, q));
}

}  // namespace ndsid::adequacy
