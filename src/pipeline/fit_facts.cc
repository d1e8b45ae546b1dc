#include "fit_facts.h"

#include <cmath>
#include <set>

#include "ndsid/common/format.h"
#include "ndsid/identify/half_estimate.h"

namespace ndsid::pipeline {
namespace {

constexpr double kDegPerRad = 180.0 / M_PI;

// The measured outputs' root mean square about zero over the segments the RMSE was taken on (the
// held-out ones where there are any): a_y [m/s^2] and the yaw rate [rad/s, -1 without one].
std::pair<double, double> Spreads(const WindowSnapshot& snap) {
  const identify::SegmentList& segs = snap.validation.empty() ? snap.training : snap.validation;
  double sa = 0, sr = 0;
  size_t na = 0, nr = 0;
  for (const stats::Segment* seg : segs) {
    if (!seg) continue;
    for (const stats::SegmentSample& s : seg->samples) {
      if (std::isfinite(s.lat_accel_mps2)) sa += double(s.lat_accel_mps2) * s.lat_accel_mps2, ++na;
      if (seg->has_yaw_rate && std::isfinite(s.yaw_rate_radps)) sr += double(s.yaw_rate_radps) * s.yaw_rate_radps, ++nr;
    }
  }
  return {na ? std::sqrt(sa / na) : -1.0, nr ? std::sqrt(sr / nr) : -1.0};
}

}  // namespace

void ScaleFloorsForSlowRoles(const WindowSnapshot& snap, double fit_rate_hz, identify::IdentificationResult& fit) {
  auto scale = [&](const char* output, double interval_s, double& floor) {
    const double p = identify::SlowOutputFloorFactor(interval_s, fit_rate_hz);
    if (!(p > 1) || !(floor > 0)) return;
    floor *= p;
    fit.identifiability.notes.push_back(Fmt("%s's noise floor x %.2f: it comes every %.0f ms, %.2f fit samples, and noise interpolated between "
                            "its frames looks that much smoother",
                            output, p, 1e3 * interval_s, p));
  };
  scale("a_y", snap.a_y_interval_s, fit.floor_a_y_mps2);
  if (fit.yaw_rate_output) scale("the yaw rate", snap.yaw_rate_interval_s, fit.floor_yaw_radps);
}

adequacy::ModelChoiceFacts ModelChoiceFactsOf(const ModelChoice& choice, double eg_se_published_deg_per_g) {
  adequacy::ModelChoiceFacts m{.gain = choice.gain, .gain_se = choice.gain_se, .eg_se_published_deg_per_g = eg_se_published_deg_per_g};
  for (const ModelAlternative& a : choice.alternatives)
    m.alternatives.push_back({.name = a.name, .scale = a.scale, .configured = a.configured, .parameter = a.parameter,
                              .evidence = a.evidence,
                              .eg_deg_per_g = a.eg_deg_per_g,
                              .eg_se_deg_per_g = a.eg_se_deg_per_g, .ruled_out = a.ruled_out, .ruled_out_why = a.ruled_out_why});
  m.notes = choice.notes;
  m.wheel_note = choice.wheel_yaw.note;
  m.fit_ruled_out_why = choice.fit_ruled_out_why;
  m.published = choice.published;
  return m;
}

adequacy::FitFacts FitFactsOf(const identify::IdentificationResult& fit, const WindowSnapshot& snap, const ModelChoice* choice) {
  adequacy::FitFacts f;
  f.termination = fit.termination;
  f.iterations = fit.iterations + fit.coarse_iterations;
  const auto [spread_a, spread_r] = Spreads(snap);
  const bool held = fit.rmse_validation_mps2 >= 0;
  f.outputs.push_back({.output = "a_y", .unit = "m/s^2", .rmse = held ? fit.rmse_validation_mps2 : fit.rmse_train_mps2,
                       .floor = fit.floor_a_y_mps2, .spread = spread_a,
                       .residuals = held ? fit.residuals_validation : fit.residuals_train});
  if (fit.yaw_rate_output) {
    const double rmse = fit.rmse_validation_yaw_radps >= 0 ? fit.rmse_validation_yaw_radps : fit.rmse_train_yaw_radps;
    f.outputs.push_back({.output = "yaw_rate", .unit = "deg/s", .rmse = rmse >= 0 ? rmse * kDegPerRad : -1,
                         .floor = fit.floor_yaw_radps >= 0 ? fit.floor_yaw_radps * kDegPerRad : -1,
                         .spread = spread_r >= 0 ? spread_r * kDegPerRad : -1, .residuals = fit.residuals_train_yaw});
  }
  auto bound = [&](const identify::ParameterEstimate& p) {
    if (p.at_bound && !p.fixed)
      f.at_bound.push_back({.name = p.name, .value = p.value, .eg_correlation = p.eg_correlation,
                            .eg_shift_deg_per_g = model::EgToDegPerG(p.eg_release_shift_rad_per_mps2)});
  };
  for (const auto& p : fit.params) bound(p);
  for (const auto& p : fit.effect_params) bound(p);
  f.eg_bound_shift_deg_per_g = model::EgToDegPerG(fit.eg_bound_shift_rad_per_mps2);
  f.eg_deg_per_g = fit.eg_deg_per_g;
  f.eg_se_deg_per_g = model::EgToDegPerG(fit.eg_se_fit_rad_per_mps2 > 0 ? fit.eg_se_fit_rad_per_mps2 : fit.eg_se_rad_per_mps2);
  f.steady_state_valid = snap.steady_state.valid;
  f.steady_state_eg_deg_per_g = model::EgToDegPerG(snap.steady_state.eg_rad_per_mps2);
  f.steady_state_eg_se_deg_per_g = model::EgToDegPerG(snap.steady_state.eg_se);
  if (fit.halves) {
    auto half = [](const identify::HalfEstimate& h) {
      return adequacy::HalfFacts{.valid = h.valid, .reason = h.reason, .eg_deg_per_g = model::EgToDegPerG(h.eg_rad_per_mps2),
                                 .eg_se_deg_per_g = model::EgToDegPerG(h.eg_se_rad_per_mps2), .drives = h.drives,
                                 .chunks = h.chunks, .in_time = h.in_time};
    };
    f.halves = std::make_pair(half(fit.halves->first), half(fit.halves->second));
  }
  std::set<int64_t> drives;
  for (const stats::Segment* seg : snap.training)
    if (seg) drives.insert(seg->drive_id);
  f.window_drives = static_cast<int>(drives.size());
  f.halves_min_chunks = identify::kClusterRobustMinChunks;
  if (choice && choice->judged) f.model_choice = ModelChoiceFactsOf(*choice, fit.eg_se_deg_per_g);
  return f;
}

}  // namespace ndsid::pipeline
