// ndsidd's identification (daemon_impl.h): the worker's job started and accepted, the monitor
// given the fitted model, the estimate and status published.
#include <spdlog/spdlog.h>

#include "daemon_impl.h"
#include "daemon_messages.h"

namespace ndsid::service {

// The monitor predicts with the fitted model, effects included (a model without effects: the
// linear one of SetParams).
void Daemon::Impl::SetMonitorModel(const identify::IdentificationResult& fit) {
  if (pipe().identifier().spec().effects().empty()) return;
  auto id = std::make_shared<identify::Identifier>(pipe().identifier());
  id->set_drive_values(fit.drive_values);
  std::vector<double> values = fit.ValuesFor(id->spec());  // a restored fit may be of another model
  monitor->SetModel(std::move(id), std::move(values));
}

void Daemon::Impl::AttachMonitor() {
  const config::Config& c = cfg();
  monitor = std::make_unique<ModelMonitor>(c.vehicle.wheelbase_m, c.sync.rate_hz, c.lcm.monitor_rate_hz);
  const auto& last = pipe().last_estimate();
  monitor->SetParams(last && last->fit.valid ? std::optional(last->fit.AsParams()) : pipe().WarmStartBase());
  if (last && last->fit.valid) SetMonitorModel(last->fit);
  // Decimated in data time by the monitor, then limited in wall-clock time: a fast replay
  // would otherwise flood the channel (thousands of messages per second, lost by receivers).
  monitor_limit = publish::WallRateLimiter(c.lcm.monitor_rate_hz);
  pipe().SetSampleObserver([this](const gate::GatedSample& g) {
    auto m = monitor->Observe(g);
    if (m && monitor_limit.Allow(MonoNs())) {
      monitor->FillModel(*m);
      sink->PublishMonitor(*m);
    }
  });
}

void Daemon::Impl::StartJob() {
  Job j;
  j.started_ns = MonoNs();
  // The worker owns copies of everything it touches (snapshot, identifier, warm start) and shares
  // the incremental prior, which is immutable; the data checks are made here meanwhile.
  j.fit = pipe().StartFit();
  spdlog::debug("identification started: {} training / {} validation segments, {:.3f} gated h", j.fit.snap->training.size(),
                j.fit.snap->validation.size(), j.fit.snap->gated_hours);
  job = std::move(j);
}

void Daemon::Impl::AcceptJob() {
  Job j = std::move(*job);
  job.reset();
  identify::IdentificationResult fit;
  try {
    fit = j.fit.result.get();
  } catch (const std::exception& e) {  // never the end of the service: an invalid estimate, logged with the reason
    fit.valid = false;
    fit.reason = std::string("identification failed: ") + e.what();
  }
  const pipeline::Estimate& e = pipe().Accept(*j.fit.snap, std::move(fit), &j.fit.data_checks, j.fit.choice.get());
  ++identifications;
  if (e.fit.valid) {
    spdlog::info("identification {}: EG {:.4e} rad/(m/s^2) = {:.3f} deg/g (sigma {:.2e}), RMSE {:.3f}/{:.3f} m/s^2, "
                 "{:.3f} gated h, {} ({:.1f} s, {})",
                 identifications, e.fit.eg_rad_per_mps2, e.fit.eg_deg_per_g, e.fit.eg_se_rad_per_mps2,
                 e.fit.rmse_train_mps2, e.fit.rmse_validation_mps2, e.gated_hours, adequacy::StateName(e.adequacy.state),
                 (MonoNs() - j.started_ns) * 1e-9, e.fit.update);
    monitor->SetParams(e.fit.AsParams());
    SetMonitorModel(e.fit);
  }
  PublishEstimate();
  Notify("STATUS=" + StatusLine(pipe().last_estimate(), pipe()));
  Persist(false);
}

void Daemon::Impl::PollJob() {
  if (job && job->fit.result.wait_for(std::chrono::seconds(0)) == std::future_status::ready) AcceptJob();
}

void Daemon::Impl::PublishEstimate() {
  sink->PublishEstimate(MakeEstimateMessage(pipe().last_estimate(), pipe(), cfg(), identifications));
}

void Daemon::Impl::PublishStatus() {
  SourceView v{source->Describe(), source_state, source->counters(), skipped_resume};
  const int64_t persisted_ns = last_persist_done_ns.load();
  const double age = persisted_ns < 0 ? -1.0 : (MonoNs() - persisted_ns) * 1e-9;
  sink->PublishStatus(MakeStatusMessage(pipe(), cfg(), v, job.has_value(), age));
}

}  // namespace ndsid::service
