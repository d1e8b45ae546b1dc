// ndsidd, the in-vehicle service: frames from SocketCAN or candump logs -> Pipeline on the
// reading thread; identification on a worker thread; estimates, status and the monitor stream
// published (LCM); learned state persisted and continued across restarts; SIGHUP reloads the
// configuration; systemd notified (READY, WATCHDOG, STATUS). See docs/daemon.md.
//
// Threads and what each owns:
//   reading thread (Run):  the frame source, the Pipeline (sync, gate, statistics, window,
//                          adequacy), the monitor, the publisher, systemd notifications, and the
//                          capture of the learned state; it never waits on a fit or a disk write.
//   identification worker: fits one immutable WindowSnapshot at a time (Pipeline::Fit touches no
//                          pipeline state); the reading thread Accepts the result.
//   persist helper:        encodes and writes an already captured state (atomic file).
//   signal handlers:       only set the atomic stop/reload flags.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "ndsid/can/frame_source.h"
#include "ndsid/config/config.h"
#include "ndsid/publish/estimate_sink.h"
#include "ndsid/sync/role_extractor.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid::service {

struct DaemonOptions {
  std::string config_path;
  bool realtime = false;           // --realtime: replay logs at recorded speed (also source.realtime)
  double speed = 1.0;              // --speed: replay at this multiple of recorded speed (implies realtime)
  double persist_interval_s = 300; // --persist-interval-s: write the learned state at least this often [s, wall]
  // Tests: make the frame source instead of the configured one (e.g. SocketCanSource::Adopt on
  // a socketpair), and/or publish into this sink instead of LCM.
  std::function<std::unique_ptr<can::FrameSource>(const config::Config&, const sync::RoleExtractor&)> source_factory;
  std::shared_ptr<publish::EstimateSink> sink;
};

// The service manager's side (sd_notify in ndsidd_main.cc; empty in tests).
struct ServiceNotifier {
  std::function<void(const std::string&)> notify;  // "READY=1", "WATCHDOG=1", "STATUS=...", "STOPPING=1", ...
  uint64_t watchdog_usec = 0;                      // sd_watchdog_enabled(); 0 = no watchdog
};

class Daemon {
 public:
  // Loads and validates the configuration and the DBC. Throws ConfigError (exit 78).
  Daemon(DaemonOptions options, ServiceNotifier notifier);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Opens the source (throws ndsid::Error when it cannot: exit 1, systemd retries), continues
  // from the learned state and runs until the logs end or a stop is requested. At the end of
  // the logs: final identification, state persisted, exit code 0. On a stop: state persisted.
  int Run();

  void RequestStop() noexcept;    // async-signal-safe
  void RequestReload() noexcept;  // async-signal-safe

  const std::optional<pipeline::Estimate>& final_estimate() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// --check-config: configuration, DBC, log files and the pipeline's fit to the DBC. Throws
// ConfigError naming file:line on the first problem.
void CheckConfig(const std::string& config_path);

// --show-state: prints the learned state of the configured vehicle (stdout). Returns 0 when a
// valid state exists, 1 otherwise.
int ShowState(const std::string& config_path);

// SIGTERM/SIGINT -> RequestStop, SIGHUP -> RequestReload on `daemon`; SIGPIPE ignored.
void InstallSignalHandlers(Daemon& daemon);

}  // namespace ndsid::service
