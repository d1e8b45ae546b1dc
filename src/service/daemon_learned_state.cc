// ndsidd's learned state (daemon_impl.h): loaded and restored at start (or quarantined), the
// resume point of a log, captured on the reading thread and written by the persist helper.
#include <spdlog/spdlog.h>

#include "daemon_impl.h"

namespace ndsid::service {

void Daemon::Impl::LoadState() {
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

// A log resumed after a restart is re-read from WarmupNs() before its resume point.
void Daemon::Impl::SetResumePoint() {
  if (!source_is_log || restored_data_time_ns == std::numeric_limits<int64_t>::min()) return;
  resume_from_ns = restored_data_time_ns - WarmupNs();
  pipe().mutable_accumulator().SkipThrough(pipe().accumulator().last_sample_ns());
}

LearnedState Daemon::Impl::Capture() {
  LearnedState st = CaptureState(pipe(), cfg(), identifications);
  st.data_time_ns = std::max(st.data_time_ns, restored_data_time_ns);
  return st;
}

// Captures on the reading thread; writes on a helper thread unless `wait` (shutdown). With
// `wait`, returns whether the state was written.
bool Daemon::Impl::Persist(bool wait) {
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

}  // namespace ndsid::service
