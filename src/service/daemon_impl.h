// Private to ndsidd: the daemon's state (Daemon::Impl) and its jobs, each implemented in its own
// file:
//   daemon.cc                 the reading thread's loop: Run, Tick, the end of the data, a stop
//   daemon_frames.cc          the frame source; feeding frames (resume skip, realtime pacing); the
//                             newest frames kept for a reload, and the SIGHUP reload itself
//   daemon_identification.cc  the identification worker's job, the monitor, publishing
//   daemon_learned_state.cc   loading, capturing and persisting the learned state; the resume point
//   daemon_estimator.cc       configuration + DBC + pipeline (daemon_estimator.h)
// Every member is owned by the reading thread unless its comment says otherwise (daemon.h).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "daemon.h"
#include "daemon_estimator.h"
#include "daemon_monitor.h"
#include "ndsid/publish/rate_limiter.h"
#include "state_store.h"

namespace ndsid::service {

// The monotonic clock [ns]: pacing, rates and ages in wall time (never the data's time).
inline int64_t MonoNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

struct Daemon::Impl {
  // Set up by the constructor.
  DaemonOptions opt;                              // the command line's options
  ServiceNotifier notifier;                       // systemd's side (empty in tests)
  Estimator est;                                  // configuration, DBC, pipeline: replaced on a reload
  std::unique_ptr<StateStore> store;              // the learned state's file
  std::shared_ptr<publish::EstimateSink> sink;    // LCM, or the tests' sink

  // The input.
  std::unique_ptr<can::FrameSource> source;       // opened by Run
  bool source_is_log = false;                     // the configured log files (resume skip, input errors)
  can::SourceState source_state = can::SourceState::kOk;  // the last Read's
  std::atomic<bool> stop{false}, reload{false};   // set by the signal handlers (RequestStop/RequestReload)

  // The monitor stream.
  std::unique_ptr<ModelMonitor> monitor;          // the fitted model's prediction against the data
  publish::WallRateLimiter monitor_limit{0};      // its messages limited in wall-clock time

  // The identification worker's job (one at a time).
  struct Job {
    pipeline::FitJob fit;    // the worker's fit of one window snapshot
    int64_t started_ns = 0;  // MonoNs() at its start
  };
  std::optional<Job> job;    // the running job, accepted by the reading thread when it is done
  int32_t identifications = 0;  // accepted so far, the restored state's included

  // The learned state.
  std::future<bool> persist_job;  // the persist helper's write (valid while one may be running)
  bool persist_disabled = false;  // the state file exists but cannot be read, and the config says run anyway
  int64_t restored_data_time_ns = std::numeric_limits<int64_t>::min();  // log frames up to this are learned
  // A log resumed after a restart is re-read from a little before restored_data_time_ns (the
  // sync stage needs every role's latest value, the gate its filters), so that the drive and
  // its gated segment go on seamlessly; the accumulator skips the samples it has already.
  int64_t resume_from_ns = std::numeric_limits<int64_t>::min();
  uint64_t skipped_resume = 0;  // frames skipped as already learned
  // Written by the persist thread, read by the reading thread for the status: atomic (it was a
  // plain int64_t, a data race).
  std::atomic<int64_t> last_persist_done_ns{-1};

  // A reload's warm-up.
  std::deque<can::CanFrame> recent;  // Remember(): the newest frames, for a reload's warm-up
  int64_t recent_window_ns = 0;      // how much of them (WarmupNs())

  // Periodic work and pacing (MonoNs()).
  int64_t last_status_ns = 0, last_watchdog_ns = 0, last_persist_ns = 0;
  int64_t pace_data0_ns = 0, pace_wall0_ns = -1;  // realtime pacing: a frame's data time against wall time

  std::optional<pipeline::Estimate> final_estimate;  // at the end of the logs, or at a stop

  const config::Config& cfg() const { return *est.config; }
  pipeline::Pipeline& pipe() { return *est.pipeline; }
  void Notify(const std::string& s) {
    if (notifier.notify) notifier.notify(s);
  }
  bool realtime() const { return opt.realtime || opt.speed != 1.0 || cfg().source.realtime; }
  void ApplyLogLevel();

  // daemon.cc: the reading thread's loop.
  int Run();
  void Tick();
  int FinishData();
  int Stop();
  int ExitCode(bool saved) const;

  // daemon_frames.cc: the input and the reload.
  void OpenSource();
  void Feed(std::span<can::CanFrame> frames);
  void Remember(std::span<const can::CanFrame> frames);
  int64_t WarmupNs() const;
  void Reload();

  // daemon_identification.cc: fits, the monitor, publishing.
  void SetMonitorModel(const identify::IdentificationResult& fit);
  void AttachMonitor();
  void StartJob();
  void AcceptJob();
  void PollJob();
  void PublishEstimate();
  void PublishStatus();

  // daemon_learned_state.cc: the learned state.
  void LoadState();
  void SetResumePoint();
  LearnedState Capture();
  bool Persist(bool wait);
};

}  // namespace ndsid::service
