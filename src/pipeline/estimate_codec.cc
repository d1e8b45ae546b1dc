#include "ndsid/pipeline/estimate_codec.h"

#include <cmath>
#include <limits>
#include <string>

#include "ndsid/identify/result_codec.h"

namespace ndsid::pipeline {

namespace {

constexpr size_t kMaxListed = 1'000'000;

size_t Count(const JsonIn& in, const char* key) {
  const uint64_t v = in.UInt64(key);
  if (v > (uint64_t{1} << 40)) in.At(key).Fail("implausible count");
  return static_cast<size_t>(v);
}

nlohmann::json CheckJson(const adequacy::Check& c) {
  return {{"name", c.name}, {"verdict", adequacy::VerdictName(c.verdict)}, {"value", c.value},
          {"informative_s", c.informative_s}, {"message", c.message}};
}

adequacy::Check CheckFromJson(const JsonIn& in) {
  adequacy::Check c;
  c.name = in.String("name");
  const std::string verdict = in.String("verdict");
  bool known = false;
  for (adequacy::Verdict v : {adequacy::Verdict::kPassed, adequacy::Verdict::kFailed, adequacy::Verdict::kSkipped}) {
    if (verdict == adequacy::VerdictName(v)) c.verdict = v, known = true;
  }
  if (!known) in.At("verdict").Fail("unknown verdict '" + verdict + "'");
  c.value = in.Number("value");
  c.informative_s = in.Number("informative_s");
  c.message = in.String("message");
  return c;
}

// The model-choice refits (pipeline/model_choice.h); only written when they were made.
nlohmann::json ModelChoiceJson(const ModelChoice& m) {
  nlohmann::json alts = nlohmann::json::array();
  for (const ModelAlternative& a : m.alternatives) {
    alts.push_back({{"name", a.name}, {"scale", a.scale}, {"fitted", a.fitted}, {"reason", a.reason},
                    {"eg_deg_per_g", a.eg_deg_per_g}, {"eg_se_deg_per_g", a.eg_se_deg_per_g},
                    {"rmse_a_y_mps2", a.rmse_a_y_mps2}, {"rmse_yaw_degps", a.rmse_yaw_degps},
                    {"ruled_out", a.ruled_out}, {"ruled_out_why", a.ruled_out_why}});
    if (a.configured) {  // model.alternatives: `scale` is the value of `parameter`
      alts.back()["configured"] = true;
      alts.back()["parameter"] = a.parameter;
    }
    if (!a.evidence.empty()) alts.back()["evidence"] = a.evidence;  // model.watch
  }
  nlohmann::json j = {{"kinematic_gain", m.gain}, {"kinematic_gain_se", m.gain_se}, {"alternatives", alts}, {"notes", m.notes},
                      {"seconds", m.seconds}, {"fit_ruled_out_why", m.fit_ruled_out_why}, {"published", m.published}};
  if (m.wheel_yaw.available || !m.wheel_yaw.note.empty())
    j["wheel_yaw"] = {{"available", m.wheel_yaw.available}, {"gyro_scale", m.wheel_yaw.scale}, {"sd", m.wheel_yaw.sd},
                      {"note", m.wheel_yaw.note}};
  return j;
}

ModelChoice ModelChoiceFromJson(const JsonIn& in) {
  ModelChoice m{.judged = true, .gain = in.Number("kinematic_gain"), .gain_se = in.Number("kinematic_gain_se")};
  const JsonIn alts = in.At("alternatives");
  for (size_t i = 0, n = alts.Size(16); i < n; ++i) {
    const JsonIn a = alts.At(i);
    m.alternatives.push_back({.name = a.String("name"), .scale = a.Number("scale"), .fitted = a.Bool("fitted"),
                              .reason = a.String("reason"), .eg_deg_per_g = a.Number("eg_deg_per_g"),
                              .eg_se_deg_per_g = a.Number("eg_se_deg_per_g"), .rmse_a_y_mps2 = a.Number("rmse_a_y_mps2"),
                              .rmse_yaw_degps = a.Number("rmse_yaw_degps"), .ruled_out = a.Bool("ruled_out"),
                              .ruled_out_why = a.String("ruled_out_why")});
    if (a.Has("configured")) {
      m.alternatives.back().configured = a.Bool("configured");
      m.alternatives.back().parameter = a.String("parameter");
    }
    if (a.Has("evidence")) m.alternatives.back().evidence = a.String("evidence");
  }
  m.notes = in.At("notes").Strings(16);
  m.seconds = in.Number("seconds");
  if (in.Has("fit_ruled_out_why")) m.fit_ruled_out_why = in.String("fit_ruled_out_why");
  if (in.Has("published")) m.published = in.String("published");
  if (in.Has("wheel_yaw")) {
    const JsonIn w = in.At("wheel_yaw");
    m.wheel_yaw = {.available = w.Bool("available"), .scale = w.Number("gyro_scale"), .sd = w.Number("sd"), .note = w.String("note")};
  }
  return m;
}

std::vector<adequacy::Check> ChecksFromJson(const JsonIn& in) {
  std::vector<adequacy::Check> out;
  for (size_t i = 0, n = in.Size(1024); i < n; ++i) out.push_back(CheckFromJson(in.At(i)));
  return out;
}

}  // namespace

nlohmann::json EstimateToJson(const Estimate& e) {
  nlohmann::json j = identify::ResultToJson(e.fit);
  j["data_time_ns"] = e.data_time_ns;
  j["gated_hours"] = e.gated_hours;
  j["window_hours"] = e.window_hours;
  j["training_segments"] = e.training_segments;
  j["validation_segments"] = e.validation_segments;
  const stats::SteadyStateEstimate& s = e.steady_state;
  j["steady_state"] = {{"valid", s.valid}, {"reason", s.reason}, {"eg_rad_per_mps2", s.eg_rad_per_mps2},
                       {"eg_se_rad_per_mps2", s.eg_se}, {"steer_ratio", s.steer_ratio},
                       {"steer_offset_rad", s.steer_offset_rad}, {"steer_offset_se_rad", s.steer_offset_se}, {"n", s.n}};
  const adequacy::Report& a = e.adequacy;
  j["adequacy"] = {{"state", adequacy::StateName(a.state)}, {"gated_hours", a.gated_hours}, {"rel_change", a.rel_change},
                   {"rel_se", a.rel_se}, {"kl_growth", a.kl_growth}, {"hours_under_tolerance", a.hours_under_tolerance},
                   {"explanation", a.explanation}};
  if (a.prior_hours > 0) {  // started from priors (adequacy::PriorCredit)
    j["adequacy"]["prior_hours"] = a.prior_hours;
    j["adequacy"]["change_from_prior"] = a.change_from_prior;
  }
  const adequacy::PlausibilityReport& p = e.plausibility;
  nlohmann::json pj = {{"passed", p.passed()}, {"reason", p.Reason()}, {"drives_checked", p.drives.size()},
                       {"drives_failed", p.drives_failed}, {"checks", nlohmann::json::array()},
                       {"failed_drives", nlohmann::json::array()}};
  for (const auto& c : p.checks) pj["checks"].push_back(CheckJson(c));
  for (const auto& d : p.drives) {
    nlohmann::json failed = nlohmann::json::array();
    for (const auto& c : d.checks)
      if (c.verdict == adequacy::Verdict::kFailed) failed.push_back(CheckJson(c));
    if (!failed.empty()) pj["failed_drives"].push_back({{"drive", d.drive_id}, {"t0_ns", d.t0_ns}, {"checks", failed}});
  }
  j["plausibility"] = std::move(pj);
  if (e.model_choice.judged) j["model_choice"] = ModelChoiceJson(e.model_choice);
  nlohmann::json ev = nlohmann::json::array();
  for (const auto& sp : e.standstill)
    ev.push_back({{"param", sp.param}, {"mean", sp.value}, {"se", sp.sd}, {"stops", sp.stops}, {"seconds", sp.seconds}});
  j["standstill"] = {{"stops", e.standstill_stops}, {"seconds", e.standstill_seconds}, {"evidence", ev}};
  return j;
}

Estimate EstimateFromJson(const JsonIn& in) {
  Estimate e;
  e.fit = identify::ResultFromJson(in);
  e.data_time_ns = in.Int64("data_time_ns");
  e.gated_hours = in.Number("gated_hours");
  e.window_hours = in.Number("window_hours");
  e.training_segments = Count(in, "training_segments");
  e.validation_segments = Count(in, "validation_segments");
  const JsonIn s = in.At("steady_state");
  stats::SteadyStateEstimate& ss = e.steady_state;
  ss.valid = s.Bool("valid");
  ss.reason = s.String("reason");
  ss.eg_rad_per_mps2 = s.Number("eg_rad_per_mps2");
  ss.eg_se = s.Number("eg_se_rad_per_mps2");
  ss.steer_ratio = s.Number("steer_ratio");
  ss.steer_offset_rad = s.Number("steer_offset_rad");
  if (s.Has("steer_offset_se_rad")) ss.steer_offset_se = s.Number("steer_offset_se_rad");  // absent in older files
  ss.n = s.Number("n");
  const JsonIn a = in.At("adequacy");
  adequacy::Report& r = e.adequacy;
  r.state = adequacy::StateFromJson(a.At("state"));
  r.gated_hours = a.Number("gated_hours");
  r.rel_change = a.Number("rel_change");
  r.rel_se = a.Number("rel_se");
  r.kl_growth = a.Number("kl_growth");
  r.hours_under_tolerance = a.Number("hours_under_tolerance");
  r.explanation = a.String("explanation");
  if (a.Has("prior_hours")) {
    r.prior_hours = a.Number("prior_hours");
    if (!(r.prior_hours >= 0 && r.prior_hours <= adequacy::kMaxPriorHours)) a.At("prior_hours").Fail("out of range");
    r.change_from_prior = a.Bool("change_from_prior");
  }
  const JsonIn p = in.At("plausibility");
  e.plausibility.checks = ChecksFromJson(p.At("checks"));
  const int64_t failed = p.Int64("drives_failed");
  if (failed < 0 || failed > static_cast<int64_t>(kMaxListed)) p.At("drives_failed").Fail("out of range");
  e.plausibility.drives_failed = static_cast<int>(failed);
  const JsonIn fd = p.At("failed_drives");
  for (size_t i = 0, n = fd.Size(kMaxListed); i < n; ++i) {
    const JsonIn d = fd.At(i);
    e.plausibility.drives.push_back(adequacy::DriveChecks{d.Int64("drive"), d.Int64("t0_ns"), ChecksFromJson(d.At("checks"))});
  }
  const JsonIn st = in.At("standstill");
  e.standstill_stops = Count(st, "stops");
  e.standstill_seconds = st.Number("seconds");
  const JsonIn ev = st.At("evidence");
  for (size_t i = 0, n = ev.Size(64); i < n; ++i) {
    const JsonIn x = ev.At(i);
    e.standstill.push_back({x.String("param"), x.Number("mean"), x.Number("se"), Count(x, "stops"), x.Number("seconds")});
  }
  if (in.Has("model_choice")) e.model_choice = ModelChoiceFromJson(in.At("model_choice"));
  return e;
}

nlohmann::json StopsToJson(const std::vector<gate::StandstillStop>& stops) {
  nlohmann::json a = nlohmann::json::array();
  for (const gate::StandstillStop& s : stops) {
    nlohmann::json j{{"drive", s.drive_id}, {"t_start_ns", s.t_start_ns}, {"seconds", s.seconds}, {"samples", s.samples},
                     {"mean_lat_accel_mps2", s.mean_lat_accel_mps2}};
    j["mean_yaw_rate_radps"] = std::isfinite(s.mean_yaw_rate_radps) ? nlohmann::json(s.mean_yaw_rate_radps) : nlohmann::json();
    a.push_back(std::move(j));
  }
  return a;
}

std::vector<gate::StandstillStop> StopsFromJson(const JsonIn& in, size_t max_stops) {
  std::vector<gate::StandstillStop> out;
  const size_t n = in.Size(max_stops);
  out.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const JsonIn j = in.At(i);
    gate::StandstillStop s;
    s.drive_id = j.Int64("drive");
    s.t_start_ns = j.Int64("t_start_ns");
    s.samples = j.UInt64("samples");
    s.seconds = j.Finite("seconds");
    s.mean_lat_accel_mps2 = j.Finite("mean_lat_accel_mps2");
    s.mean_yaw_rate_radps = j.Number("mean_yaw_rate_radps");  // null: no yaw rate
    // A stop is at most a (very long) parking of 10^7 s; the mean a_y a few g at the most.
    if (s.drive_id < 0 || s.samples == 0 || !(s.seconds > 0 && s.seconds <= 1e7) || !(std::abs(s.mean_lat_accel_mps2) <= 1e3) ||
        !(std::isnan(s.mean_yaw_rate_radps) || std::abs(s.mean_yaw_rate_radps) <= 1e3))
      j.Fail("out of range (drive, samples, seconds, mean a_y or mean yaw rate)");
    out.push_back(s);
  }
  return out;
}

}  // namespace ndsid::pipeline
