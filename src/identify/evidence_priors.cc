#include "evidence_priors.h"

#include <cmath>
#include <cstdio>
#include <set>
#include <vector>

#include "ndsid/identify/identifier.h"
#include "ndsid/model/effect_library.h"
#include "ndsid/stats/speed_scale.h"
#include "quadratic_prior.h"

namespace ndsid::identify {
namespace {
// The base parameters EG depends on (model::SelfSteerGradient).
constexpr int kEgParams[] = {model::kMass, model::kStiffFront, model::kStiffRear, model::kCgToFront};
}  // namespace

bool HasConfiguredPrior(const config::IdentificationConfig& config, const std::string& name) {
  return std::any_of(config.priors.begin(), config.priors.end(), [&](const config::ParameterPrior& pr) { return pr.name == name; });
}

std::vector<Identifier::StandstillPrior> Identifier::StandstillPriors(const std::vector<gate::StandstillStop>& stops,
                                                                      const std::set<int64_t>& drives) {
  // Each stop is one observation (its mean over often hundreds of correlated samples): the
  // spread between stops holds the sensor noise, the cross-slope where the car stood and any
  // drift of the offset, so the standard error of the mean over the stops is honest without a
  // noise model. Floor: 1 % of the effect's typical magnitude (identical stops, e.g. a coarsely
  // quantised sensor, would otherwise make an infinitely sure prior).
  std::vector<StandstillPrior> out;
  auto add = [&](const char* effect, auto value_of) {
    const auto e = model::EffectLibrary::Builtin().Find(effect);
    if (!e || e->info().params.empty()) return;
    const std::string& param = e->info().params[0].name;
    const double typical = e->info().params[0].typical;
    std::vector<double> v;
    double seconds = 0;
    for (const gate::StandstillStop& st : stops) {
      if (!drives.empty() && !drives.count(st.drive_id)) continue;
      const double x = value_of(st);
      if (!std::isfinite(x)) continue;
      v.push_back(x);
      seconds += st.seconds;
    }
    if (v.size() < kMinStops) return;
    const double n = static_cast<double>(v.size());
    double mean = 0, ss = 0;
    for (double x : v) mean += x / n;
    for (double x : v) ss += (x - mean) * (x - mean);
    const double se = std::sqrt(ss / (n - 1) / n);
    out.push_back({param, mean, std::max(se, 0.01 * typical), v.size(), seconds, effect});
  };
  add("gyro_offset", [](const gate::StandstillStop& st) { return st.mean_yaw_rate_radps; });
  add("accel_bias", [](const gate::StandstillStop& st) { return st.mean_lat_accel_mps2; });
  return out;
}

void EvidencePriors::Build(const FitSettings& settings, const ParameterBox& box, const SegmentList& training,
                           const std::vector<gate::StandstillStop>& stops) {
  AddConfigured(settings, box);
  configured_ = costs_.size();
  AddStandstill(settings, box, training, stops);
  AddSpeedScale(settings, box, training);
}

void EvidencePriors::Add(const ParameterBox& box, int i, double value, double sd) {
  costs_.push_back(std::make_unique<PriorCost>(box.size(), i, box.scale[i], value, sd));
}

void EvidencePriors::AddConfigured(const FitSettings& settings, const ParameterBox& box) {
  for (const config::ParameterPrior& pr : settings.config.priors) {
    if (pr.name == config::kEgPriorName) {
      AddEgPrior(settings, box, pr);
      continue;
    }
    for (int i = 0; i < box.size(); ++i) {
      if (settings.spec.param_name(i) != pr.name || box.bounds[i].fixed) continue;
      Add(box, i, pr.value, pr.sd);
      prior_notes_.push_back("prior on " + pr.name + ": " + std::to_string(pr.value) + " +- " + std::to_string(pr.sd) +
                             " (model.priors); its standard error includes the prior");
    }
  }
}

// A prior on EG pulls the base parameters EG depends on (m, cv, ch, lv); none of them free: none.
void EvidencePriors::AddEgPrior(const FitSettings& settings, const ParameterBox& box, const config::ParameterPrior& pr) {
  const bool any_free = std::any_of(std::begin(kEgParams), std::end(kEgParams), [&](int i) { return !box.bounds[i].fixed; });
  if (!any_free) return;
  const double to_rad = 1.0 / model::EgToDegPerG(1.0);
  costs_.push_back(std::make_unique<EgPriorCost>(box.size(), box.scale, settings.wheelbase_m, pr.value * to_rad, pr.sd * to_rad));
  char note[200];
  std::snprintf(note, sizeof note, "prior on EG: %.4g +- %.2g deg/g (model.priors); its standard error includes the prior",
                pr.value, pr.sd);
  prior_notes_.push_back(note);
}

bool EgPriorCost::Evaluate(double const* const* p, double* r, double** jac) const {
  Eigen::VectorXd row(parameter_block_sizes()[0]);
  r[0] = sqrt_w_ * Standardised(p[0], row);
  if (jac && jac[0]) Eigen::Map<Eigen::VectorXd>(jac[0], row.size()) = sqrt_w_ * row;
  return true;
}

void EgPriorCost::AddInformation(const double* theta, Eigen::MatrixXd& info) const {
  Eigen::VectorXd row(parameter_block_sizes()[0]);
  Standardised(theta, row);
  info += row * row.transpose();
}

double EgPriorCost::Standardised(const double* theta, Eigen::VectorXd& row) const {
  const std::vector<double> t(theta, theta + scale_.size());
  double base[model::kNumParams];
  for (int i = 0; i < model::kNumParams; ++i) base[i] = t[i] * scale_[i];
  const double eg = model::SelfSteerGradient(model::Params<double>::FromArray(base), wheelbase_m_);
  row = EgGradientTheta(t, scale_, wheelbase_m_, std::vector<bool>(scale_.size(), false)) / sd_;
  return (eg - value_) / sd_;
}

// Standstill evidence: a prior from the stops of the training drives on gyro_offset and
// accel_bias (docs/two-outputs.md). A configured prior on the same parameter wins.
void EvidencePriors::AddStandstill(const FitSettings& settings, const ParameterBox& box, const SegmentList& training,
                                   const std::vector<gate::StandstillStop>& stops) {
  std::set<int64_t> training_drives;
  for (const stats::Segment* seg : training) training_drives.insert(seg->drive_id);
  // A per-drive parameter's entry of the vector is the value of the drives that have no value of
  // their own (the reference drive; every drive before the first per-drive fit): their stops.
  std::set<int64_t> slot_drives;
  for (int64_t d : training_drives)
    if (!settings.drive_overrides.count(d)) slot_drives.insert(d);
  const std::vector<Identifier::StandstillPrior> slot_evidence = Identifier::StandstillPriors(stops, slot_drives);
  for (Identifier::StandstillPrior sp : Identifier::StandstillPriors(stops, training_drives)) {
    const bool configured = HasConfiguredPrior(settings.config, sp.param);
    for (int i = model::kNumParams; i < box.size() && !configured; ++i) {
      if (settings.spec.param_name(i) != sp.param || box.bounds[i].fixed) continue;
      if (settings.spec.effect_param(i)->per_drive && slot_drives.size() != training_drives.size()) {
        const auto it = std::find_if(slot_evidence.begin(), slot_evidence.end(),
                                     [&](const Identifier::StandstillPrior& x) { return x.param == sp.param; });
        if (it == slot_evidence.end()) continue;
        sp = *it;
      }
      Add(box, i, sp.value, sp.sd);
      char note[256];
      std::snprintf(note, sizeof note, "standstill evidence on %s: %.4g +- %.2g from %zu stops (%.0f s); its standard error includes it",
                    sp.param.c_str(), sp.value, sp.sd, sp.stops, sp.seconds);
      evidence_notes_.push_back(note);
    }
  }
}

// The speed signal's scale read against a_x (stats/speed_scale.h): a prior on speed_scale,
// which a_y and r cannot tell from an accelerometer scale. A configured prior wins.
void EvidencePriors::AddSpeedScale(const FitSettings& settings, const ParameterBox& box, const SegmentList& training) {
  if (HasConfiguredPrior(settings.config, "speed_scale")) return;
  for (int i = model::kNumParams; i < box.size(); ++i) {
    if (settings.spec.param_name(i) != "speed_scale" || box.bounds[i].fixed) continue;
    const stats::SpeedScaleEvidence ev = stats::EstimateSpeedScale(training);
    if (!ev.available) {
      evidence_notes_.push_back(ev.note + ": no prior on speed_scale from it");
      break;
    }
    Add(box, i, ev.scale, ev.prior_sd);
    char note[320];
    std::snprintf(note, sizeof note, "%s: a prior on speed_scale, sd %.2g (with the accelerometer's own scale tolerance); "
                  "its standard error includes it", ev.note.c_str(), ev.prior_sd);
    evidence_notes_.push_back(note);
  }
}

void EvidencePriors::AddTo(ceres::Problem& problem, double* theta) const {
  for (const auto& pc : costs_) problem.AddResidualBlock(pc.get(), nullptr, theta);
}

void EvidencePriors::SetWeight(double level) {
  weight_ = level;
  for (auto& pc : costs_) pc->set_weight(weight_);
}

Eigen::MatrixXd EvidencePriors::InformationTheta(const double* theta, const std::vector<int>& free, bool configured_only) const {
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(nf, nf);
  if (costs_.empty()) return info;
  const Eigen::MatrixXd all = InformationAll(theta, costs_.front()->parameter_block_sizes()[0], configured_only);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) info(a, b) = all(free[a], free[b]);
  return info;
}

Eigen::MatrixXd EvidencePriors::InformationAll(const double* theta, int np, bool configured_only) const {
  Eigen::MatrixXd info = Eigen::MatrixXd::Zero(np, np);
  const size_t n = configured_only ? configured_ : costs_.size();
  for (size_t k = 0; k < n; ++k) costs_[k]->AddInformation(theta, info);
  return info;
}

void EvidencePriors::AddPull(const double* theta, Eigen::VectorXd& grad, Eigen::MatrixXd& hessian) const {
  const long np = grad.size();
  std::vector<double> jrow(static_cast<size_t>(np));
  for (const auto& pc : costs_) {
    double res = 0;
    const double* pp[] = {theta};
    double* jj[] = {jrow.data()};
    pc->Evaluate(pp, &res, jj);
    const Eigen::Map<const Eigen::VectorXd> jv(jrow.data(), np);
    grad += jv * res;
    hessian += jv * jv.transpose();
  }
}

std::vector<std::string> EvidencePriors::Notes() const {
  std::vector<std::string> notes = evidence_notes_;
  notes.insert(notes.end(), prior_notes_.begin(), prior_notes_.end());
  return notes;
}

}  // namespace ndsid::identify
