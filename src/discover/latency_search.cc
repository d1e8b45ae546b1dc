// Step 0's search for one role's latency (latency_search.h).
#include "latency_search.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/model_output.h"
#include "ndsid/model/model_spec.h"

namespace ndsid::discover {
using namespace identify;  // the estimator this stage builds on
using config::Role;
namespace {

float stats::SegmentSample::*Field(Role role) {
  switch (role) {
    case Role::kSteeringWheelAngle: return &stats::SegmentSample::steer_rad;
    case Role::kSpeed: return &stats::SegmentSample::speed_mps;
    case Role::kYawRate: return &stats::SegmentSample::yaw_rate_radps;
    case Role::kLongitudinalAcceleration: return &stats::SegmentSample::long_accel_mps2;
    default: return nullptr;
  }
}

// x(k + shift) by linear interpolation, held at the ends.
double ReadShifted(const std::vector<stats::SegmentSample>& s, float stats::SegmentSample::*field, double index) {
  const double last = static_cast<double>(s.size() - 1);
  if (index <= 0) return s.front().*field;
  if (index >= last) return s.back().*field;
  const size_t i = static_cast<size_t>(index);
  const double w = index - static_cast<double>(i);
  return (1 - w) * (s[i].*field) + w * (s[i + 1].*field);
}

// How badly a fit matches its training data, to choose between two fits of one model on one data
// set from different starts: minus the likelihood with each output's variance estimated, i.e.
// the product of the outputs' training RMSEs (a_y's alone with one output). Lower is better.
double Misfit(const IdentificationResult& fit) {
  return fit.yaw_rate_output && fit.rmse_train_yaw_radps > 0 ? fit.rmse_train_mps2 * fit.rmse_train_yaw_radps : fit.rmse_train_mps2;
}

}  // namespace

std::vector<stats::Segment> Shifted(const SegmentList& segments, const std::vector<RoleLatency>& latencies, bool trim) {
  std::vector<stats::Segment> out;
  out.reserve(segments.size());
  for (const stats::Segment* seg : segments) {
    stats::Segment copy = *seg;
    double ahead = 0, behind = 0;  // the largest shifts forward and back [samples]
    for (const RoleLatency& l : latencies) {
      const auto field = Field(l.role);
      if (!l.apply || field == nullptr || seg->samples.size() < 2) continue;
      const double shift = l.latency_s / seg->dt_s;
      ahead = std::max(ahead, shift);
      behind = std::max(behind, -shift);
      for (size_t k = 0; k < seg->samples.size(); ++k) {
        copy.samples[k].*field = static_cast<float>(ReadShifted(seg->samples, field, static_cast<double>(k) + shift));
      }
    }
    if (trim && (ahead > 0 || behind > 0)) {
      const size_t n = copy.samples.size();
      const size_t front = std::min(n, static_cast<size_t>(std::ceil(behind)));
      const size_t back = std::min(n - front, static_cast<size_t>(std::ceil(ahead)));
      copy.samples.erase(copy.samples.end() - static_cast<long>(back), copy.samples.end());
      copy.samples.erase(copy.samples.begin(), copy.samples.begin() + static_cast<long>(front));
      copy.t0_ns += static_cast<int64_t>(std::llround(static_cast<double>(front) * seg->dt_s * 1e9));
    }
    out.push_back(std::move(copy));
  }
  return out;
}

namespace {

std::vector<stats::Segment> ShiftOne(const SegmentList& segments, Role role, double shift_s) {
  RoleLatency l;
  l.role = role;
  l.latency_s = shift_s;
  l.apply = true;
  return Shifted(segments, {l}, false);
}

struct Profile {
  std::vector<double> shift, rss;
};

// Minimum of a profile refined by a parabola through its neighbours; the curvature gives the
// standard error with the residual variance sigma2_tau (sigma^2 times the autocorrelation time).
void Refine(const Profile& p, double sigma2_tau, RoleLatency& out) {
  const size_t n = p.rss.size();
  const size_t i = static_cast<size_t>(std::min_element(p.rss.begin(), p.rss.end()) - p.rss.begin());
  out.latency_s = p.shift[i];
  if (i == 0 || i + 1 >= n) {
    out.note = "the minimum lies at the edge of the searched range";
    return;
  }
  const double h = p.shift[i + 1] - p.shift[i];
  const double rm = p.rss[i - 1], r0 = p.rss[i], rp = p.rss[i + 1];
  const double curv = (rp - 2 * r0 + rm) / (2 * h * h);  // RSS ~ r0 + curv (shift - shift*)^2
  if (!(curv > 0)) {
    out.note = "the profile is flat: the data do not determine it";
    return;
  }
  out.latency_s = p.shift[i] - 0.5 * h * (rp - rm) / (rp - 2 * r0 + rm);
  out.se_s = std::sqrt(sigma2_tau / curv);
  out.determined = std::isfinite(out.se_s);
}

// Residuals of one output per chunk after its burn-in: a_y, or the yaw rate where it is
// measured (chunks without a modelled yaw rate are left out).
std::vector<std::vector<double>> ChunkResiduals(const Identifier& id, const std::vector<double>& params,
                                                const SegmentList& segments, bool yaw_rate) {
  std::vector<std::vector<double>> res;
  for (const ChunkOutput& c : SimulateChunks(id, params, segments)) {
    if (yaw_rate && c.yaw_rate_model_radps.size() != c.n) continue;
    std::vector<double> e;
    for (size_t k = c.burn_in; k < c.n; ++k) {
      const stats::SegmentSample& s = c.segment->samples[c.first + k];
      if (!yaw_rate) {
        e.push_back(s.lat_accel_mps2 - c.a_y_model_mps2[k]);
      } else if (std::isfinite(s.yaw_rate_radps)) {
        e.push_back(s.yaw_rate_radps - c.yaw_rate_model_radps[k]);
      }
    }
    res.push_back(std::move(e));
  }
  return res;
}

std::vector<double> Grid(const AlignmentOptions& o) {
  std::vector<double> g;
  const int n = static_cast<int>(std::lround((o.max_s - o.min_s) / o.step_s));
  for (int i = 0; i <= n; ++i) g.push_back(o.min_s + i * o.step_s);
  return g;
}

// RSS over the grid of shifts of `role`; rmse_of(shifted, &n) scores the shifted copies.
template <class Score>
Profile ShiftProfile(const SegmentList& training, Role role, const AlignmentOptions& o, Score rmse_of) {
  Profile p;
  for (double s : Grid(o)) {
    const std::vector<stats::Segment> shifted = ShiftOne(training, role, s);
    size_t n = 0;
    const double rmse = rmse_of(Pointers(shifted), &n);
    p.shift.push_back(s);
    p.rss.push_back(rmse * rmse * static_cast<double>(n));
  }
  return p;
}

// Profile of the model's RSS over shifts of one input role, parameters held.
RoleLatency InputProfile(const Identifier& id, const std::vector<double>& params, const SegmentList& training, Role role,
                         const AlignmentOptions& o) {
  RoleLatency out;
  out.role = role;
  out.method = "RSS profile over shifts, parameters held";
  const Profile p = ShiftProfile(training, role, o, [&](const SegmentList& shifted, size_t* n) { return id.Rmse(params, shifted, n); });
  Refine(p, ResidualNoiseLevel(ChunkResiduals(id, params, training, false)), out);
  return out;
}

}  // namespace

RoleLatency YawRateProfile(const Identifier& two, const std::vector<double>& params, const SegmentList& training,
                           const AlignmentOptions& o) {
  RoleLatency out;
  out.role = Role::kYawRate;
  out.method = "yaw-rate RSS profile over shifts, parameters held";
  const Profile p = ShiftProfile(training, Role::kYawRate, o,
                                 [&](const SegmentList& shifted, size_t* n) { return two.RmseYawRate(params, shifted, n); });
  Refine(p, ResidualNoiseLevel(ChunkResiduals(two, params, training, true)), out);
  return out;
}

namespace {

// One Gauss-Newton step of the model (effects `names`) and a shift (`effect`, at 0 on `data`)
// from the fit `params` of `id`: the score test of the shift with every parameter free (the
// one-step estimate diagnose ranks effects by), the parameters on a bound held as the refit's
// active set holds them. se_s: its standard error (CandidateScore::se: model-based, or the
// cluster sandwich at the step where larger).
struct ShiftStep {
  bool valid = false;
  double step_s = 0, se_s = 0;
};
ShiftStep OneStep(const Identifier& id, const std::vector<double>& params, const SegmentList& data,
                  const std::vector<std::string>& names, const std::string& effect) {
  Identifier probe(id.config(), id.wheelbase_m(), model::ModelSpec::FromNames(names, id.spec().library()));
  probe.set_standstill(id.standstill());
  probe.set_drive_values(id.drive_values());
  DiagnosisOptions score;
  score.candidates = {effect};
  score.hold_on_bound = true;
  const Diagnosis d = Diagnose(probe, Extend(id.spec(), params, probe.spec()), data, score);
  ShiftStep out;
  for (const CandidateScore& c : d.ranked) {
    if (c.param != effect + "_s" || !(c.se > 0) || !std::isfinite(c.se) || !std::isfinite(c.one_step)) continue;
    out = {true, c.one_step, c.se};
  }
  return out;
}

// The joint refit is skipped when the shift's first Gauss-Newton step from the current fit (its
// score test with the parameters free, OneStep) stays below half the floor, and the held
// profile's minimum does too or a second step from the profile's minimum lands within half the
// floor of the first: only a nonlinearity that moves the refit by more than half the floor from
// both steps could get the shift applied. Returns that first step when it suffices, else an
// invalid step. probe_names: the model's effects and the nuisance, without the shift's.
ShiftStep OneStepSuffices(const Identifier& id, const std::vector<double>& params, const SegmentList& training, Role role,
                          const std::string& effect, const std::vector<std::string>& probe_names, double profile_s,
                          double floor_s) {
  const ShiftStep at_zero = OneStep(id, params, training, probe_names, effect);
  bool skip = at_zero.valid && std::abs(at_zero.step_s) < 0.5 * floor_s;
  ShiftStep there;
  if (skip && std::abs(profile_s) >= 0.5 * floor_s) {
    // The held profile points elsewhere (the fit absorbs part of a shift, or a nuisance effect
    // fitted along is missing from it): one more step, from the profile's minimum on data
    // shifted by it. Both steps must land on the same shift.
    const std::vector<stats::Segment> shifted = ShiftOne(training, role, profile_s);
    there = OneStep(id, params, Pointers(shifted), probe_names, effect);
    skip = there.valid && std::abs(profile_s + there.step_s - at_zero.step_s) < 0.5 * floor_s;
  }
  spdlog::debug("alignment: {} profile {:.1f} ms, one-step {:.1f} +- {:.1f} ms{}: joint refit {}", effect + "_s", 1e3 * profile_s,
                1e3 * at_zero.step_s, 1e3 * at_zero.se_s,
                there.valid ? fmt::format(", from the profile's minimum {:.1f} ms", 1e3 * (profile_s + there.step_s)) : "",
                skip ? "skipped" : "needed");
  return skip ? at_zero : ShiftStep{};
}

// The shift parameter `name` of a valid fit (nullptr otherwise).
const ParameterEstimate* ShiftOf(const IdentificationResult& f, const std::string& name) {
  const auto p = std::find_if(f.effect_params.begin(), f.effect_params.end(), [&](const auto& e) { return e.name == name; });
  return f.valid && p != f.effect_params.end() ? &*p : nullptr;
}

// A shift about to be applied: the refit also from the usual start (the configured initial
// values) with the shift where the first refit put it, and the one with the lower misfit kept.
// The fit on the skewed data has bent its parameters to absorb the shift; from there a 150 ms gyro
// latency read as 161 ms in a worse basin (from the usual start: 153 ms).
void PreferUsualStart(const Identifier& joint, const SegmentList& training, const std::string& name, const AlignmentOptions& o,
                      double floor_s, IdentificationResult& fit) {
  const ParameterEstimate* first = ShiftOf(fit, name);
  if (first == nullptr || !(std::abs(first->value) >= floor_s) || !(std::abs(first->value) > o.z_apply * first->se)) return;
  std::vector<double> usual = joint.FullVector(joint.WarmStart(std::nan(""), std::nan("")));
  for (int i = model::kNumParams; i < joint.spec().num_params(); ++i) {
    if (joint.spec().param_name(i) == name) usual[static_cast<size_t>(i)] = first->value;
  }
  IdentificationResult fresh = joint.Identify(training, {}, std::optional<std::vector<double>>(usual));
  spdlog::debug("alignment: {} joint refit from the skewed fit {:.1f} ms (misfit {:.6g}), from the usual start {:.1f} ms (misfit {:.6g})",
                name, 1e3 * first->value, Misfit(fit), ShiftOf(fresh, name) ? 1e3 * ShiftOf(fresh, name)->value : std::nan(""),
                fresh.valid ? Misfit(fresh) : std::nan(""));
  if (ShiftOf(fresh, name) != nullptr && Misfit(fresh) < Misfit(fit)) fit = std::move(fresh);
}

}  // namespace

// An input (steering: steer_delay; speed: speed_delay): the profile finds the basin, a joint
// refit of model and shift (the role's delay effect) the estimate and its standard error with
// every parameter free (a profile with the parameters held underestimates a shift the fit has
// partly absorbed: a 250 ms speed latency read 189 +- 5 ms held, docs/two-outputs.md).
// `nuisance`: effects fitted along (not in the model yet) that the shift would otherwise stand in
// for; their values are dropped from `refitted`.
// `refitted`: the model's parameters from the joint refit (for data aligned by the result).
// `floor_s`: the smallest latency applied. The joint refit corrects what the held profile misses
// (a shift the fit partly absorbs); when the shift's score test shows it below half the floor
// (OneStepSuffices) the refit is skipped and the first step reported with its standard error
// (docs/model-workflow.md, step 0).
RoleLatency JointLatency(const Identifier& id, const std::vector<double>& params, const SegmentList& training,
                         Role role, const std::string& effect, const std::vector<std::string>& nuisance,
                         const AlignmentOptions& o, double floor_s, std::vector<double>& refitted) {
  RoleLatency out = role == Role::kYawRate ? YawRateProfile(id, params, training, o) : InputProfile(id, params, training, role, o);
  for (const auto& e : id.spec().effects()) {
    if (e->info().name == effect) {
      out.determined = false;
      out.note = effect + " is in the model";
      return out;
    }
  }
  if (!out.note.empty() && out.note.find("edge") == std::string::npos) return out;
  std::vector<std::string> names;
  for (const auto& e : id.spec().effects()) names.push_back(e->info().name);
  names.push_back(effect);
  for (const std::string& n : nuisance) {
    if (std::find(names.begin(), names.end(), n) == names.end()) names.push_back(n);
  }
  const std::string name = effect + "_s";
  if (out.determined) {
    std::vector<std::string> probe_names = names;
    probe_names.erase(std::find(probe_names.begin(), probe_names.end(), effect));
    if (const ShiftStep first = OneStepSuffices(id, params, training, role, effect, probe_names, out.latency_s, floor_s); first.valid) {
      out.latency_s = first.step_s;
      out.se_s = first.se_s;
      out.method = "RSS profile over shifts, then a score test of model and shift (one Gauss-Newton step)";
      return out;
    }
  }
  const Identifier joint(id.config(), id.wheelbase_m(), model::ModelSpec::FromNames(names, id.spec().library()));
  std::vector<double> warm = Extend(id.spec(), params, joint.spec());
  for (int i = model::kNumParams; i < joint.spec().num_params(); ++i) {
    if (joint.spec().param_name(i) == name) warm[static_cast<size_t>(i)] = std::clamp(out.latency_s, o.min_s, o.max_s);
  }
  IdentificationResult fit = joint.Identify(training, {}, std::optional<std::vector<double>>(warm));
  out.method = "RSS profile over shifts, then a joint refit of model and shift";
  PreferUsualStart(joint, training, name, o, floor_s, fit);
  if (!fit.valid || fit.effect_params.empty()) {
    out.determined = false;
    out.note = "the joint refit failed: " + fit.reason;
    return out;
  }
  const ParameterEstimate* shift = ShiftOf(fit, name);
  if (shift == nullptr) {
    out.determined = false;
    out.note = "the joint refit has no " + name;
    return out;
  }
  const ParameterEstimate& d = *shift;
  refitted = Extend(joint.spec(), fit.AllValues(), id.spec());
  out.latency_s = d.value;
  out.se_s = d.se;
  out.determined = !d.at_bound && d.se > 0 && std::isfinite(d.se);
  out.note = d.at_bound ? "the shift ends on the edge of the searched range" : "";
  return out;
}

}  // namespace ndsid::discover
