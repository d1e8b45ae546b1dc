#include <chrono>
#include <cmath>
#include <cstdio>

#include "daemon_messages.h"
#include "ndsid/gate/gate.h"

namespace ndsid::service {

namespace {
int64_t WallUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}
}  // namespace

const char* SourceStateName(can::SourceState s) {
  switch (s) {
    case can::SourceState::kOk: return "OK";
    case can::SourceState::kTimeout: return "TIMEOUT";
    case can::SourceState::kEnd: return "END";
    case can::SourceState::kDisconnected: return "DISCONNECTED";
  }
  return "?";
}

publish::EstimateMessage MakeEstimateMessage(const std::optional<pipeline::Estimate>& e, const pipeline::Pipeline& pipeline,
                                             const config::Config& config, int32_t identifications) {
  publish::EstimateMessage m;
  m.publish_utime = WallUtime();
  m.vehicle = config.vehicle.name;
  m.identifications = identifications;
  m.effects = config.model_effects;
  const adequacy::Report& a = e ? e->adequacy : pipeline.adequacy().last();
  m.adequacy_state = adequacy::StateName(a.state);
  m.adequacy_rel_change = a.rel_change;
  m.adequacy_rel_sigma = a.rel_se;
  m.adequacy_kl_growth = a.kl_growth;
  m.adequacy_hours_under_tolerance = a.hours_under_tolerance;
  m.adequacy_explanation = a.explanation;
  m.gated_hours = pipeline.accumulator().gated_hours();
  m.window_hours = pipeline.accumulator().window_hours();
  if (!e) {
    m.utime = pipeline.data_time_ns() / 1000;
    m.valid = false;
    m.reason = "no identification yet";
    if (m.adequacy_explanation.empty()) m.adequacy_explanation = "no estimate yet";
    return m;
  }
  const identify::IdentificationResult& f = e->fit;
  m.utime = e->data_time_ns / 1000;
  m.valid = f.valid;
  m.reason = f.valid ? "" : (f.reason.empty() ? "not valid" : f.reason);
  m.eg_rad_per_mps2 = f.eg_rad_per_mps2;
  m.eg_sigma_rad_per_mps2 = f.eg_se_rad_per_mps2;
  m.eg_deg_per_g = f.eg_deg_per_g;
  m.eg_sigma_deg_per_g = f.eg_se_deg_per_g;
  for (int i = 0; i < model::kNumParams; ++i) {
    m.params.push_back({model::kParamNames[i], model::kParamUnits[i], f.params[i].value, f.params[i].se,
                        f.params[i].fixed, f.params[i].at_bound});
  }
  for (const identify::ParameterEstimate& p : f.effect_params) {
    m.params.push_back({p.name, p.unit, p.value, p.se, p.fixed, p.at_bound});
  }
  m.rmse_train_mps2 = f.rmse_train_mps2;
  m.rmse_validation_mps2 = f.rmse_validation_mps2;
  m.se_method = f.se_method;
  m.training_segments = static_cast<int32_t>(e->training_segments);
  m.validation_segments = static_cast<int32_t>(e->validation_segments);
  m.steady_state_valid = e->steady_state.valid;
  m.steady_state_eg_rad_per_mps2 = e->steady_state.eg_rad_per_mps2;
  m.steady_state_eg_sigma_rad_per_mps2 = e->steady_state.eg_se;
  m.steady_state_steer_ratio = e->steady_state.steer_ratio;
  for (const adequacy::Check& c : e->plausibility.checks)
    m.checks.push_back({c.name, adequacy::VerdictName(c.verdict), c.value, c.message});
  return m;
}

publish::StatusMessage MakeStatusMessage(const pipeline::Pipeline& pipeline, const config::Config& config, const SourceView& source,
                                         bool identification_running, double last_persist_age_s) {
  publish::StatusMessage m;
  m.utime = pipeline.data_time_ns() / 1000;
  m.publish_utime = WallUtime();
  m.vehicle = config.vehicle.name;
  m.source = source.description;
  m.source_state = SourceStateName(source.state);
  const auto& ex = pipeline.extractor().counters();
  m.frames_read = static_cast<int64_t>(source.counters.frames);
  m.frames_decoded = static_cast<int64_t>(ex.used);
  m.frames_unknown = static_cast<int64_t>(ex.unknown_id);
  m.frames_too_short = static_cast<int64_t>(ex.too_short);
  m.malformed = static_cast<int64_t>(source.counters.malformed);
  m.bus_errors = static_cast<int64_t>(source.counters.error_frames);
  m.dropped = static_cast<int64_t>(source.counters.dropped);
  m.reconnects = static_cast<int64_t>(source.counters.reconnects);
  m.time_backwards = static_cast<int64_t>(source.counters.time_backwards);
  m.frames_skipped_resume = static_cast<int64_t>(source.skipped_resume);
  const gate::GateCounters& gc = pipeline.gate().counters();
  for (int v = 0; v < gate::kNumVerdicts; ++v) {
    m.gate_reason.push_back(gate::VerdictName(static_cast<gate::Verdict>(v)));
    m.gate_count.push_back(static_cast<int64_t>(gc.by_verdict[v]));
  }
  m.drives = static_cast<int64_t>(gc.drives);
  m.gated_hours = pipeline.accumulator().gated_hours();
  m.standstill_samples = static_cast<int64_t>(pipeline.gate().standstill().samples);
  m.standstill_lat_accel_mps2 = pipeline.gate().standstill().mean_mps2();
  m.identification_running = identification_running;
  m.last_persist_age_s = last_persist_age_s;
  return m;
}

std::string StatusLine(const std::optional<pipeline::Estimate>& e, const pipeline::Pipeline& pipeline) {
  char buf[256];
  const double hours = pipeline.accumulator().gated_hours();
  if (!e) {
    std::snprintf(buf, sizeof buf, "COLLECTING: no estimate yet, %.2f gated h", hours);
  } else if (!e->fit.valid) {
    std::snprintf(buf, sizeof buf, "%s: estimate not valid (%s), %.2f gated h", adequacy::StateName(e->adequacy.state),
                  e->fit.reason.c_str(), hours);
  } else {
    const double rel = e->fit.eg_rad_per_mps2 != 0 ? 100 * e->fit.eg_se_rad_per_mps2 / std::abs(e->fit.eg_rad_per_mps2) : 0;
    std::snprintf(buf, sizeof buf, "%s: EG %.4e rad/(m/s^2) = %.3f deg/g +-%.2f %%, %.2f gated h",
                  adequacy::StateName(e->adequacy.state), e->fit.eg_rad_per_mps2, e->fit.eg_deg_per_g, rel, hours);
  }
  return buf;
}

std::string FinalLine(const std::optional<pipeline::Estimate>& e, const pipeline::Pipeline& pipeline) {
  char buf[512];
  if (!e) {
    std::snprintf(buf, sizeof buf, "final estimate: none (valid=0), gated_hours=%.6f", pipeline.accumulator().gated_hours());
    return buf;
  }
  const auto& f = e->fit;
  std::snprintf(buf, sizeof buf,
                "final estimate: valid=%d EG=%.9e rad/(m/s^2) sigma=%.3e EG_deg_per_g=%.6f gated_hours=%.6f "
                "rmse_train=%.4f rmse_validation=%.4f adequacy=%s%s%s",
                f.valid ? 1 : 0, f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.eg_deg_per_g, e->gated_hours,
                f.rmse_train_mps2, f.rmse_validation_mps2, adequacy::StateName(e->adequacy.state),
                f.valid ? "" : " reason=", f.valid ? "" : f.reason.c_str());
  return buf;
}

}  // namespace ndsid::service
