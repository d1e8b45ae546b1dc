// The identifier's public face (identifier.h): the result's accessors, the warm start, the
// RMSE of given parameters, and the dispatch of Identify to one window fit (window_fit.h) or to
// the per-drive alternation (per_drive_fit.cc).
#include "ndsid/identify/identifier.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>

#include "residual_sums.h"
#include "window_fit.h"

namespace ndsid::identify {

std::string CeresVersion() { return CERES_VERSION_STRING; }

model::Params<double> IdentificationResult::AsParams() const {
  double p[6];
  for (int i = 0; i < 6; ++i) p[i] = params[i].value;
  return model::Params<double>::FromArray(p);
}

std::vector<double> IdentificationResult::ValuesFor(const model::ModelSpec& spec) const {
  std::vector<double> v;
  for (const auto& p : params) v.push_back(p.value);
  for (int i = model::kNumParams; i < spec.num_params(); ++i) {
    const std::string name = spec.param_name(i);
    const auto it = std::find_if(effect_params.begin(), effect_params.end(), [&](const ParameterEstimate& p) { return p.name == name; });
    v.push_back(it != effect_params.end() ? it->value : spec.effect_param(i)->neutral);
  }
  return v;
}

size_t IdentificationResult::NumEstimated() const {
  size_t n = 0;
  for (const auto& p : params) n += p.fixed ? 0 : 1;
  for (const auto& p : effect_params) n += p.fixed ? 0 : 1;
  for (const DriveValue& v : drive_values) n += v.reference || v.validation ? 0 : 1;
  return n;
}

std::vector<double> IdentificationResult::AllValues() const {
  std::vector<double> v;
  for (const auto& p : params) v.push_back(p.value);
  for (const auto& p : effect_params) v.push_back(p.value);
  return v;
}

Identifier::Identifier(const config::IdentificationConfig& config, double wheelbase_m, model::ModelSpec spec)
    : config_(config), wheelbase_m_(wheelbase_m), spec_(std::move(spec)) {}

model::Params<double> Identifier::WarmStart(double steer_ratio, double eg) const {
  double p[6];
  for (int i = 0; i < 6; ++i) p[i] = config_.params[i].initial;
  auto clamp = [&](int i, double v) { return std::clamp(v, config_.params[i].lower, config_.params[i].upper); };
  if (std::isfinite(steer_ratio) && steer_ratio > 0) p[model::kSteerRatio] = clamp(model::kSteerRatio, steer_ratio);
  if (std::isfinite(eg)) {
    // EG = m/l (lh/cv - lv/ch)  =>  cv = lh / (EG l/m + lv/ch)
    const double l = wheelbase_m_, m = p[model::kMass], lv = p[model::kCgToFront], lh = l - lv;
    const double denom = eg * l / m + lv / p[model::kStiffRear];
    if (denom > 0) p[model::kStiffFront] = clamp(model::kStiffFront, lh / denom);
  }
  return model::Params<double>::FromArray(p);
}

std::vector<double> Identifier::FullVector(const model::Params<double>& p) const {
  std::vector<double> v = {p.m, p.Jz, p.cv, p.ch, p.lv, p.is};
  for (int i = model::kNumParams; i < spec_.num_params(); ++i) v.push_back(spec_.effect_param(i)->initial);
  return v;
}

double Identifier::Rmse(const model::Params<double>& p, const SegmentList& segments, size_t* count) const {
  return Rmse(FullVector(p), segments, count);
}

double Identifier::Rmse(const std::vector<double>& params, const SegmentList& segments, size_t* count) const {
  const ErrorSums s = SimulatedErrorSums(spec_, wheelbase_m_, MakeChunks(segments, config_.chunk_s, config_.burn_in_s, drive_overrides_),
                                         params, config_.burn_in_s, false, config_.threads);
  if (count) *count = s.na;
  return RootMean(s.a, s.na);
}

double Identifier::RmseYawRate(const std::vector<double>& params, const SegmentList& segments, size_t* count) const {
  const ErrorSums s = SimulatedErrorSums(spec_, wheelbase_m_, MakeChunks(segments, config_.chunk_s, config_.burn_in_s, drive_overrides_),
                                         params, config_.burn_in_s, true, config_.threads);
  if (count) *count = s.nr;
  return RootMean(s.r, s.nr);
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<model::Params<double>>& warm_start) const {
  return Identify(training, validation,
                  warm_start ? std::optional<std::vector<double>>(FullVector(*warm_start)) : std::nullopt);
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<std::vector<double>>& warm_start) const {
  return spec_.per_drive_params().empty() ? IdentifyAtDriveValues(training, validation, warm_start)
                                         : IdentifyPerDrive(training, validation, warm_start);
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<std::vector<double>>& warm_start,
                                          const IncrementalUpdate& update) const {
  if (!spec_.per_drive_params().empty()) return IdentifyPerDrive(training, validation, warm_start);
  return IdentifyAtDriveValues(training, validation, warm_start, &update);
}

DriveOverrides OverridesFor(const std::vector<DriveValue>& values, const model::ModelSpec& spec) {
  DriveOverrides out;
  for (const DriveValue& v : values) {
    if (v.reference) continue;  // the reference drive's values are the parameter vector's
    const int i = spec.param_index(v.param);
    const model::EffectParam* ep = i >= 0 ? spec.effect_param(i) : nullptr;
    if (ep && ep->per_drive) out[v.drive_id].emplace_back(i, v.value);
  }
  return out;
}

void Identifier::set_drive_values(const std::vector<DriveValue>& values) {
  drive_values_ = values;
  drive_overrides_ = OverridesFor(values, spec_);
}

IdentificationResult Identifier::IdentifyAtDriveValues(const SegmentList& training, const SegmentList& validation,
                                                       const std::optional<std::vector<double>>& warm_start,
                                                       const IncrementalUpdate* update) const {
  return WindowFit(*this, training, validation, warm_start, update).Run();
}

}  // namespace ndsid::identify
