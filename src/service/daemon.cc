#include <fcntl.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <deque>
#include <cstdio>
#include <filesystem>
#include <future>
#include <limits>
#include <thread>

#include "daemon.h"
#include "daemon_messages.h"
#include "daemon_monitor.h"
#include "daemon_source.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/can/socketcan_source.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/publish/lcm_publisher.h"
#include "ndsid/publish/rate_limiter.h"
#include "state_store.h"

namespace ndsid::service {

namespace {

constexpr int kReadTimeout_ms = 100;       // bounds the reaction to signals and the watchdog period
constexpr size_t kBatchFrames = 1024;      // frames per Read() as fast as possible
constexpr size_t kRealtimeBatchFrames = 64;
constexpr int64_t kMaxPaceSleep_ns = 50'000'000;

int64_t MonoNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Configuration, DBC and the pipeline built on them: replaced together on a reload.
struct Estimator {
  std::unique_ptr<config::Config> config;
  std::unique_ptr<dbc::Database> db;
  std::unique_ptr<pipeline::Pipeline> pipeline;
};

Estimator BuildEstimator(const std::string& path) {
  Estimator e;
  e.config = std::make_unique<config::Config>(config::LoadConfig(path));
  const config::Config& c = *e.config;
  try {
    e.db = std::make_unique<dbc::Database>(dbc::ParseDbcFile(c.dbc));
  } catch (const ConfigError&) {
    throw;
  } catch (const Error& err) {
    throw ConfigError(FormatLocation(c.path, 0, 0, std::string("dbc: ") + err.what()));
  }
  config::ValidateAgainstDbc(c, *e.db);
  if (c.source.type == config::SourceConfig::Type::kLog) {
    for (const std::string& log : c.source.logs) {
      if (::access(log.c_str(), R_OK) != 0) {
        throw ConfigError(FormatLocation(c.path, 0, 0, "source.logs: cannot read '" + log + "'"));
      }
      try {
        can::DetectLogFormat(log);  // a format we cannot read fails --check-config
      } catch (const Error& err) {
        throw ConfigError(FormatLocation(c.path, 0, 0, std::string("source.logs: ") + err.what()));
      }
    }
  }
  if (c.lcm.url.find("://") == std::string::npos) {
    throw ConfigError(FormatLocation(c.path, 0, 0, "lcm.url: '" + c.lcm.url + "' is not an LCM URL (e.g. udpm://239.255.76.67:7667?ttl=0)"));
  }
  e.pipeline = std::make_unique<pipeline::Pipeline>(c, *e.db);
  return e;
}

std::shared_ptr<publish::EstimateSink> MakeLcmSink(const config::Config& c) {
  return std::make_shared<publish::LcmPublisher>(c.lcm.url, publish::LcmChannels{c.lcm.estimate_channel,
                                                                                c.lcm.status_channel,
                                                                                c.lcm.monitor_channel});
}

std::atomic<Daemon*> g_signal_target{nullptr};

void OnSignal(int sig) {
  Daemon* d = g_signal_target.load();
  if (!d) return;
  if (sig == SIGHUP) {
    d->RequestReload();
  } else {
    d->RequestStop();
  }
}

}  // namespace

struct Daemon::Impl {
  DaemonOptions opt;
  ServiceNotifier notifier;
  Estimator est;
  std::unique_ptr<StateStore> store;
  std::shared_ptr<publish::EstimateSink> sink;
  std::unique_ptr<can::FrameSource> source;
  bool source_is_log = false;
  std::unique_ptr<ModelMonitor> monitor;
  publish::WallRateLimiter monitor_limit{0};
  std::atomic<bool> stop{false}, reload{false};

  struct Job {
    pipeline::FitJob fit;
    int64_t started_ns = 0;
  };
  std::optional<Job> job;
  std::future<bool> persist_job;
  bool persist_disabled = false;  // the state file exists but cannot be read, and the config says run anyway
  int32_t identifications = 0;
  int64_t restored_data_time_ns = std::numeric_limits<int64_t>::min();  // log frames up to this are learned
  // A log resumed after a restart is re-read from a little before restored_data_time_ns (the
  // sync stage needs every role's latest value, the gate its filters), so that the drive and
  // its gated segment go on seamlessly; the accumulator skips the samples it has already.
  int64_t resume_from_ns = std::numeric_limits<int64_t>::min();
  std::deque<can::CanFrame> recent;  // Remember(): the newest frames, for a reload's warm-up
  int64_t recent_window_ns = 0;
  uint64_t skipped_resume = 0;
  can::SourceState source_state = can::SourceState::kOk;
  int64_t last_status_ns = 0, last_watchdog_ns = 0, last_persist_ns = 0;
  // Written by the persist thread, read by the reading thread for the status: atomic (it was a
  // plain int64_t, a data race).
  std::atomic<int64_t> last_persist_done_ns{-1};
  int64_t pace_data0_ns = 0, pace_wall0_ns = -1;
  std::optional<pipeline::Estimate> final_estimate;

  const config::Config& cfg() const { return *est.config; }
  pipeline::Pipeline& pipe() { return *est.pipeline; }
  void Notify(const std::string& s) {
    if (notifier.notify) notifier.notify(s);
  }
  bool realtime() const { return opt.realtime || opt.speed != 1.0 || cfg().source.realtime; }

  void ApplyLogLevel() { spdlog::set_level(spdlog::level::from_str(cfg().log_level)); }

  // The monitor predicts with the fitted model, effects included (a model without effects: the
  // linear one of SetParams).
  void SetMonitorModel(const identify::IdentificationResult& fit) {
    if (pipe().identifier().spec().effects().empty()) return;
    auto id = std::make_shared<identify::Identifier>(pipe().identifier());
    id->set_drive_values(fit.drive_values);
    std::vector<double> values = fit.ValuesFor(id->spec());  // a restored fit may be of another model
    monitor->SetModel(std::move(id), std::move(values));
  }

  void AttachMonitor() {
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

  void LoadState() {
    if (const int n = store->RemoveTemporaries(); n > 0)
      spdlog::info("state: removed {} temporary file(s) an interrupted write left in {}", n, cfg().state_dir);
    StateStore::LoadResult r = store->Load();
    if (r.unreadable) {
      if (!cfg().run_without_persisting_if_unreadable) throw ConfigError("state: " + r.message);  // exit 78: no restart loop
      // By configuration (state_unreadable: run_without_persisting): estimate from scratch, and
      // never write, so the unreadable file is neither replaced nor lost.
      persist_disabled = true;
      spdlog::error("state: {}; running WITHOUT persisting (state_unreadable: run_without_persisting): nothing learned "
                    "in this run is saved, the file is left as it is",
                    r.message);
      return;
    }
    if (!r.state) {
      if (r.message.find("moved aside") != std::string::npos) {
        spdlog::warn("{}", r.message);
      } else {
        spdlog::info("{}", r.message);
      }
      return;
    }
    try {
      std::string dropped;
      RestoreState(pipe(), cfg(), *r.state, dropped);
      if (!dropped.empty()) spdlog::warn("learned state: last estimate dropped ({}); statistics kept", dropped);
      identifications = r.state->identifications;
      restored_data_time_ns = r.state->data_time_ns;
      spdlog::info("{}: {:.4f} gated h, {} drives, {} window segments, {} identifications, data up to {:.6f} s",
                   r.message, pipe().accumulator().gated_hours(), pipe().accumulator().drives().size(),
                   pipe().accumulator().window().size(), identifications, restored_data_time_ns * 1e-9);
    } catch (const StateFileError& e) {
      const std::string moved = store->Quarantine(e.kind() == StateFileError::Kind::kForeign ? "foreign" : "corrupt");
      spdlog::warn("learned state {} rejected ({}): moved aside to {}, starting fresh", store->path(), e.what(), moved);
    }
  }

  void OpenSource() {
    const config::Config& c = cfg();
    if (opt.source_factory) {
      source = opt.source_factory(c, pipe().extractor());
      source_is_log = false;
    } else if (c.source.type == config::SourceConfig::Type::kLog) {
      source = std::make_unique<LogSequence>(c.source.logs);
      source_is_log = true;
    } else {
      can::SocketCanOptions o;
      o.interface = c.source.interface;
      for (const auto& id : pipe().extractor().NeededIds()) o.ids.push_back({id.id, id.extended});
      source = std::make_unique<can::SocketCanSource>(std::move(o));
      source_is_log = false;
    }
  }

  // Resume skip (logs only: a live clock may legitimately be behind a state learned from a
  // log), realtime pacing, then the pipeline.
  void Feed(std::span<can::CanFrame> frames) {
    if (source_is_log && resume_from_ns != std::numeric_limits<int64_t>::min()) {
      size_t keep = 0;
      for (const can::CanFrame& f : frames) {
        if (f.timestamp_ns <= resume_from_ns) {
          ++skipped_resume;
        } else {
          frames[keep++] = f;
        }
      }
      frames = frames.first(keep);
    }
    if (frames.empty()) return;
    Remember(frames);
    if (!realtime()) {
      pipe().ProcessFrames(frames, source->bus_names());
      return;
    }
    size_t start = 0;
    for (size_t i = 0; i < frames.size() && !stop; ++i) {
      if (pace_wall0_ns < 0) {
        pace_wall0_ns = MonoNs();
        pace_data0_ns = frames[i].timestamp_ns;
      }
      const double speed = opt.speed > 0 ? opt.speed : 1.0;
      const int64_t due = pace_wall0_ns + static_cast<int64_t>(static_cast<double>(frames[i].timestamp_ns - pace_data0_ns) / speed);
      if (due <= MonoNs()) continue;
      pipe().ProcessFrames(frames.subspan(start, i - start), source->bus_names());
      start = i;
      for (int64_t now = MonoNs(); now < due && !stop; now = MonoNs()) {
        std::this_thread::sleep_for(std::chrono::nanoseconds(std::min(due - now, kMaxPaceSleep_ns)));
        Tick();
      }
    }
    pipe().ProcessFrames(frames.subspan(start), source->bus_names());
  }

  void StartJob() {
    Job j;
    j.started_ns = MonoNs();
    // The worker owns copies of everything it touches (snapshot, identifier, warm start) and shares
    // the incremental prior, which is immutable; the data checks are made here meanwhile.
    j.fit = pipe().StartFit();
    spdlog::debug("identification started: {} training / {} validation segments, {:.3f} gated h", j.fit.snap->training.size(),
                  j.fit.snap->validation.size(), j.fit.snap->gated_hours);
    job = std::move(j);
  }

  void AcceptJob() {
    Job j = std::move(*job);
    job.reset();
    identify::IdentificationResult fit;
    try {
      fit = j.fit.result.get();
    } catch (const std::exception& e) {  // never the end of the service: an invalid estimate, logged with the reason
      fit.valid = false;
      fit.reason = std::string("identification failed: ") + e.what();
    }
    const pipeline::Estimate& e = pipe().Accept(*j.fit.snap, std::move(fit), &j.fit.data_checks);
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

  void PollJob() {
    if (job && job->fit.result.wait_for(std::chrono::seconds(0)) == std::future_status::ready) AcceptJob();
  }

  void PublishEstimate() { sink->PublishEstimate(MakeEstimateMessage(pipe().last_estimate(), pipe(), cfg(), identifications)); }

  void PublishStatus() {
    SourceView v{source->Describe(), source_state, source->counters(), skipped_resume};
    const int64_t persisted_ns = last_persist_done_ns.load();
    const double age = persisted_ns < 0 ? -1.0 : (MonoNs() - persisted_ns) * 1e-9;
    sink->PublishStatus(MakeStatusMessage(pipe(), cfg(), v, job.has_value(), age));
  }

  LearnedState Capture() {
    LearnedState st = CaptureState(pipe(), cfg(), identifications);
    st.data_time_ns = std::max(st.data_time_ns, restored_data_time_ns);
    return st;
  }

  // Captures on the reading thread; writes on a helper thread unless `wait` (shutdown). With
  // `wait`, returns whether the state was written.
  bool Persist(bool wait) {
    if (persist_disabled) return true;  // state_unreadable: run_without_persisting (said at start)
    if (persist_job.valid()) {
      if (!wait && persist_job.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return true;
      persist_job.get();
    }
    last_persist_ns = MonoNs();
    auto write = [this, st = std::make_shared<LearnedState>(Capture())] {
      try {
        store->Save(*st);
        last_persist_done_ns = MonoNs();
        spdlog::debug("learned state written to {} ({:.4f} gated h)", store->path(), st->data_time_ns * 1e-9);
        return true;
      } catch (const std::exception& e) {
        spdlog::error("cannot write learned state: {}", e.what());
        return false;
      }
    };
    if (wait) return write();
    persist_job = std::async(std::launch::async, write);
    return true;
  }

  // The exit code at the end: 0, or kExitIo (with the reason logged) when input was lost or the
  // final save failed.
  int ExitCode(bool saved) const {
    const size_t input_errors = source_is_log ? static_cast<const LogSequence&>(*source).input_errors() : 0;
    if (input_errors > 0) spdlog::error("exit {}: {} log file(s) could not be read to the end", kExitIo, input_errors);
    if (!saved) spdlog::error("exit {}: the learned state could not be saved at exit", kExitIo);
    return input_errors == 0 && saved ? 0 : kExitIo;
  }

  void Tick() {
    PollJob();
    if (!job && !reload && pipe().IdentificationDue()) StartJob();
    const int64_t now = MonoNs();
    if (now - last_status_ns >= static_cast<int64_t>(1e9 / cfg().lcm.status_rate_hz)) {
      last_status_ns = now;
      PublishStatus();
      PublishEstimate();  // repeated, so a late subscriber sees the current estimate
      Notify("STATUS=" + StatusLine(pipe().last_estimate(), pipe()));
    }
    if (notifier.watchdog_usec > 0 && now - last_watchdog_ns >= static_cast<int64_t>(notifier.watchdog_usec) * 1000 / 3) {
      last_watchdog_ns = now;
      Notify("WATCHDOG=1");
    }
    if (now - last_persist_ns >= static_cast<int64_t>(opt.persist_interval_s * 1e9)) Persist(false);
  }

  void Reload() {
    reload = false;
    Notify("RELOADING=1");
    spdlog::info("SIGHUP: reloading {}", opt.config_path);
    try {
      Estimator next = BuildEstimator(opt.config_path);
      const config::Config& n = *next.config;
      if (n.vehicle.name != cfg().vehicle.name) {
        throw ConfigError("vehicle.name changed from '" + cfg().vehicle.name + "' to '" + n.vehicle.name +
                          "': another vehicle's learned state; restart the service to switch");
      }
      std::shared_ptr<publish::EstimateSink> next_sink = sink;
      const auto& a = cfg().lcm;
      const auto& b = n.lcm;
      if (!opt.sink && (a.url != b.url || a.estimate_channel != b.estimate_channel || a.status_channel != b.status_channel ||
                        a.monitor_channel != b.monitor_channel)) {
        next_sink = MakeLcmSink(n);
      }
      std::string dropped;
      RestoreState(*next.pipeline, n, Capture(), dropped);
      if (!dropped.empty()) spdlog::warn("reload: last estimate dropped under the new configuration ({})", dropped);
      if (n.source.type != cfg().source.type || n.source.logs != cfg().source.logs ||
          n.source.interface != cfg().source.interface || n.source.bus != cfg().source.bus) {
        spdlog::warn("reload: source changes take effect at the next start");
      }
      if (persist_job.valid()) persist_job.get();
      store = std::make_unique<StateStore>(n.state_dir, n.vehicle.name);
      next.pipeline->mutable_accumulator().SkipThrough(next.pipeline->accumulator().last_sample_ns());
      est = std::move(next);
      sink = std::move(next_sink);
      AttachMonitor();
      // Warm the new pipeline up on the newest frames (the accumulator skips what it has).
      const std::vector<can::CanFrame> warmup(recent.begin(), recent.end());
      if (source) pipe().ProcessFrames(warmup, source->bus_names());
      recent_window_ns = WarmupNs();
      ApplyLogLevel();
      spdlog::info("configuration reloaded; learned state kept ({:.4f} gated h)", pipe().accumulator().gated_hours());
    } catch (const std::exception& e) {
      spdlog::error("reload rejected, keeping the running configuration: {}", e.what());
    }
    Notify("READY=1");
  }

  // Data a fresh pipeline needs before its samples match the running one's: every role's latest
  // value (the sync stage) and the gate's filters: twice the longest role timeout plus 2 s.
  int64_t WarmupNs() const {
    double timeout_s = 0;
    for (const auto& r : cfg().roles)
      if (r) timeout_s = std::max(timeout_s, r->timeout_s);
    for (const auto& v : cfg().validity) timeout_s = std::max(timeout_s, v.timeout_s);
    return static_cast<int64_t>((2.0 + 2.0 * timeout_s) * 1e9);
  }

  // A log resumed after a restart is re-read from WarmupNs() before its resume point.
  void SetResumePoint() {
    if (!source_is_log || restored_data_time_ns == std::numeric_limits<int64_t>::min()) return;
    resume_from_ns = restored_data_time_ns - WarmupNs();
    pipe().mutable_accumulator().SkipThrough(pipe().accumulator().last_sample_ns());
  }

  // The newest WarmupNs() of frames, replayed into the new pipeline of a SIGHUP reload (the
  // source goes on and cannot be re-read), so that the drive's gated segment goes on too.
  void Remember(std::span<const can::CanFrame> frames) {
    if (frames.empty()) return;
    if (!recent.empty() && frames.front().timestamp_ns < recent.back().timestamp_ns) recent.clear();  // stamps went back
    try {
      recent.insert(recent.end(), frames.begin(), frames.end());
    } catch (...) {  // out of memory: a reload then cuts the segment, nothing else
      recent.clear();
      return;
    }
    const int64_t keep_from = frames.back().timestamp_ns - recent_window_ns;
    while (!recent.empty() && recent.front().timestamp_ns < keep_from) recent.pop_front();
  }

  int Run() {
    ApplyLogLevel();
    LoadState();
    AttachMonitor();
    OpenSource();
    SetResumePoint();
    recent_window_ns = WarmupNs();
    spdlog::info("ndsidd: vehicle {}, reading {}{}, publishing on {}", cfg().vehicle.name, source->Describe(),
                 realtime() ? " (realtime)" : "", opt.sink ? "a test sink" : cfg().lcm.url);
    Notify("READY=1");
    Notify("STATUS=" + StatusLine(pipe().last_estimate(), pipe()));
    PublishEstimate();
    last_persist_ns = MonoNs();
    std::vector<can::CanFrame> buf(realtime() ? kRealtimeBatchFrames : kBatchFrames);
    bool end_of_data = false;
    while (!stop) {
      if (reload && !job) Reload();
      const can::ReadResult r = source->Read(buf, kReadTimeout_ms);
      if (r.state != source_state && r.state == can::SourceState::kDisconnected) spdlog::warn("source {} disconnected", source->Describe());
      source_state = r.state;
      if (r.count > 0) Feed(std::span(buf.data(), r.count));
      if (r.state == can::SourceState::kEnd) {
        end_of_data = true;
        break;
      }
      Tick();
    }
    return end_of_data ? FinishData() : Stop();
  }

  // End of the logs: final identification, persist, exit 0 (kExitIo: see ExitCode).
  int FinishData() {
    if (skipped_resume > 0) spdlog::info("skipped {} frames already in the learned state", skipped_resume);
    if (job) {
      job->fit.result.wait();
      AcceptJob();
    }
    pipe().Finish();
    pipe().IdentifyNow(true);  // the final fit: the whole window's optimum
    ++identifications;
    final_estimate = pipe().last_estimate();
    const std::string line = FinalLine(final_estimate, pipe());
    spdlog::info("{}", line);
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
    PublishEstimate();
    PublishStatus();
    Notify("STOPPING=1");
    return ExitCode(Persist(true));
  }

  // A stop request: persist first (a SIGKILL after the stop timeout then loses nothing), then
  // let a running identification finish and persist again.
  int Stop() {
    Notify("STOPPING=1");
    spdlog::info("stopping: writing learned state to {}", store->path());
    bool saved = Persist(true);
    if (job) {
      spdlog::info("waiting for the running identification (started {:.1f} s ago)", (MonoNs() - job->started_ns) * 1e-9);
      job->fit.result.wait();
      AcceptJob();
      saved = Persist(true);
    }
    final_estimate = pipe().last_estimate();
    return ExitCode(saved);
  }
};

Daemon::Daemon(DaemonOptions options, ServiceNotifier notifier) : impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  d.opt = std::move(options);
  d.notifier = std::move(notifier);
  d.est = BuildEstimator(d.opt.config_path);
  d.store = std::make_unique<StateStore>(d.cfg().state_dir, d.cfg().vehicle.name);
  d.sink = d.opt.sink ? d.opt.sink : MakeLcmSink(d.cfg());
}

Daemon::~Daemon() {
  Daemon* self = this;
  g_signal_target.compare_exchange_strong(self, nullptr);
  if (impl_->persist_job.valid()) impl_->persist_job.wait();
  if (impl_->job) impl_->job->fit.result.wait();
}

int Daemon::Run() { return impl_->Run(); }
void Daemon::RequestStop() noexcept { impl_->stop = true; }
void Daemon::RequestReload() noexcept { impl_->reload = true; }
const std::optional<pipeline::Estimate>& Daemon::final_estimate() const { return impl_->final_estimate; }

void CheckConfig(const std::string& config_path) {
  const Estimator e = BuildEstimator(config_path);
  std::printf("%s: configuration OK (vehicle %s, DBC %s, %s)\n", config_path.c_str(), e.config->vehicle.name.c_str(),
              e.config->dbc.c_str(),
              e.config->source.type == config::SourceConfig::Type::kLog
                  ? (std::to_string(e.config->source.logs.size()) + " log file(s)").c_str()
                  : ("socketcan " + e.config->source.interface).c_str());
}

int ShowState(const std::string& config_path) {
  const config::Config c = config::LoadConfig(config_path);
  StateStore store(c.state_dir, c.vehicle.name);
  std::printf("state file: %s\n", store.path().c_str());
  LearnedState st;
  try {
    st = DecodeState(ReadWholeFile(store.path()), c.vehicle.name);
  } catch (const std::exception& e) {
    std::printf("not usable: %s\n", e.what());
    return 1;
  }
  stats::Accumulator acc(c, c.sync.rate_hz);
  try {
    acc.FromJson(JsonIn(st.accumulator, "state.accumulator"));
  } catch (const std::exception& e) {
    std::printf("not usable: %s\n", e.what());
    return 1;
  }
  size_t used = 0;
  for (const auto& d : acc.drives()) used += d.used ? 1 : 0;
  std::printf("vehicle: %s\ndata_time_s: %.6f\ngated_hours: %.6f\ndrives: %zu (%zu used)\nwindow: %zu segments, %.4f h\n"
              "identifications: %d\n",
              st.vehicle.c_str(), st.data_time_ns * 1e-9, acc.gated_hours(), acc.drives().size(), used, acc.window().size(),
              acc.window_hours(), st.identifications);
  {
    double seconds = 0;
    for (const gate::StandstillStop& s : st.stops) seconds += s.seconds;
    std::printf("standstill: %zu stops, %.2f s\n", st.stops.size(), seconds);
  }
  if (st.last_estimate) {
    const auto& f = st.last_estimate->fit;
    const std::string why = CheckEstimate(*st.last_estimate, c);
    std::printf("last estimate: valid=%d EG=%.9e rad/(m/s^2) sigma=%.3e EG_deg_per_g=%.6f%s%s\n", f.valid ? 1 : 0,
                f.eg_rad_per_mps2, f.eg_se_rad_per_mps2, f.eg_deg_per_g, why.empty() ? "" : " REJECTED: ", why.c_str());
  } else {
    std::printf("last estimate: none\n");
  }
  return 0;
}

void InstallSignalHandlers(Daemon& daemon) {
  g_signal_target = &daemon;
  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;  // no SA_RESTART: a blocking read returns at once and the loop sees the flag
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaction(sig, &sa, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
}

}  // namespace ndsid::service
