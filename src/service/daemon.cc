// ndsidd's reading thread (daemon.h): Run's loop, the periodic work of Tick, the end of the data
// and a stop; the Daemon's public face and the signal handlers. The jobs it calls are in the
// files daemon_impl.h lists.
#include <signal.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <vector>

#include "daemon_impl.h"
#include "daemon_messages.h"
#include "daemon_source.h"

namespace ndsid::service {

namespace {

constexpr int kReadTimeout_ms = 100;       // bounds the reaction to signals and the watchdog period
constexpr size_t kBatchFrames = 1024;      // frames per Read() as fast as possible
constexpr size_t kRealtimeBatchFrames = 64;

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

void Daemon::Impl::ApplyLogLevel() { spdlog::set_level(spdlog::level::from_str(cfg().log_level)); }

int Daemon::Impl::Run() {
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

// The periodic work between reads: a finished fit accepted, the next one started when due, the
// status, the watchdog, the learned state.
void Daemon::Impl::Tick() {
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

// End of the logs: final identification, persist, exit 0 (kExitIo: see ExitCode).
int Daemon::Impl::FinishData() {
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
int Daemon::Impl::Stop() {
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

// The exit code at the end: 0, or kExitIo (with the reason logged) when input was lost or the
// final save failed.
int Daemon::Impl::ExitCode(bool saved) const {
  const size_t input_errors = source_is_log ? static_cast<const LogSequence&>(*source).input_errors() : 0;
  if (input_errors > 0) spdlog::error("exit {}: {} log file(s) could not be read to the end", kExitIo, input_errors);
  if (!saved) spdlog::error("exit {}: the learned state could not be saved at exit", kExitIo);
  return input_errors == 0 && saved ? 0 : kExitIo;
}

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
