// ndsidd's input (daemon_impl.h): the frame source, feeding its frames to the pipeline (the
// resume skip, realtime pacing), the newest frames kept for a reload, and the SIGHUP reload.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <thread>

#include "daemon_impl.h"
#include "daemon_source.h"
#include "ndsid/can/socketcan_source.h"

namespace ndsid::service {

namespace {

constexpr int64_t kMaxPaceSleep_ns = 50'000'000;

}  // namespace

void Daemon::Impl::OpenSource() {
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
void Daemon::Impl::Feed(std::span<can::CanFrame> frames) {
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

// The newest WarmupNs() of frames, replayed into the new pipeline of a SIGHUP reload (the
// source goes on and cannot be re-read), so that the drive's gated segment goes on too.
void Daemon::Impl::Remember(std::span<const can::CanFrame> frames) {
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

// Data a fresh pipeline needs before its samples match the running one's: every role's latest
// value (the sync stage) and the gate's filters: twice the longest role timeout plus 2 s.
int64_t Daemon::Impl::WarmupNs() const {
  double timeout_s = 0;
  for (const auto& r : cfg().roles)
    if (r) timeout_s = std::max(timeout_s, r->timeout_s);
  for (const auto& v : cfg().validity) timeout_s = std::max(timeout_s, v.timeout_s);
  return static_cast<int64_t>((2.0 + 2.0 * timeout_s) * 1e9);
}

// SIGHUP: a new estimator from the configuration file, the learned state carried over, the
// newest frames replayed into it; on any error the running configuration is kept.
void Daemon::Impl::Reload() {
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

}  // namespace ndsid::service
