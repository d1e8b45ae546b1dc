#include "fleet_reduce.h"

#include <chrono>
#include <memory>
#include <span>

#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"
#include "ndsid/sync/time_base.h"
#include "replay_document.h"
#include "replay_runner.h"

namespace ndsid::desk {
namespace {

constexpr size_t kHeadFrames = sync::TimeBase::kConfirm + 1;

bool Near(int64_t a, int64_t b) { return a - b <= sync::TimeBase::kJump && b - a <= sync::TimeBase::kJump; }

// Where the reading of the logs begins: the first frames' time stamps, and the frame whose value
// starts the sync stage (the frames up to it are fed one at a time to find it).
struct StartWatch {
  std::vector<int64_t> head;  // time stamps of the first kHeadFrames frames
  bool sync_started = false;

  void Note(const can::CanFrame& f) {
    if (head.size() < kHeadFrames) head.push_back(f.timestamp_ns);
  }
  bool Steady() const {
    if (head.size() < kHeadFrames) return false;
    for (size_t i = 1; i < head.size(); ++i)
      if (!Near(head[i], head.front()) || !Near(head[i], head[i - 1])) return false;
    return true;
  }
};

// Feeds one batch of frames; until the sync stage has started, frame by frame, noting the frame
// that started it.
void Feed(pipeline::Pipeline& p, std::span<const can::CanFrame> batch, const std::vector<std::string>& buses,
          StartWatch& watch, pipeline::LogReduction& r) {
  size_t i = 0;
  for (; i < batch.size() && !watch.sync_started; ++i) {
    watch.Note(batch[i]);
    p.ProcessFrames(batch.subspan(i, 1), buses);
    const sync::SyncCounters& sc = p.sync().counters();
    if (sc.values > sc.non_finite) {  // a value was taken: the sync stage has started
      watch.sync_started = true;
      r.sync_start_frame_ns = batch[i].timestamp_ns;
      const sync::TimeBaseCounters& tb = p.time_base().counters();
      r.sync_start_exact = tb.spikes_dropped == 0 && tb.steps_back == 0 && tb.steps_forward == 0;
    }
  }
  for (size_t k = i; k < batch.size() && watch.head.size() < kHeadFrames; ++k) watch.Note(batch[k]);
  if (i < batch.size()) p.ProcessFrames(batch.subspan(i), buses);
}

}  // namespace

pipeline::LogReduction ReduceLogs(const config::Config& config, const dbc::Database& db, const std::vector<std::string>& logs) {
  for (const std::string& path : logs) can::DetectLogFormat(path);  // every file readable before any work
  pipeline::Pipeline p(config, db);
  p.mutable_accumulator().RecordWindowSteps();
  pipeline::LogReduction r;
  r.logs = logs;
  p.SetSampleObserver([&r](const gate::GatedSample& g) {
    if (r.first_sample_ns < 0) r.first_sample_ns = g.sample.t_ns;
    r.last_sample_ns = g.sample.t_ns;
  });
  StartWatch watch;
  std::vector<can::CanFrame> frames(256);
  for (const std::string& path : logs) {
    const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(path);
    for (;;) {
      const can::ReadResult rr = log->Read(frames, 0);
      Feed(p, std::span<const can::CanFrame>(frames.data(), rr.count), log->bus_names(), watch, r);
      if (rr.state == can::SourceState::kEnd) break;
    }
    const can::SourceCounters& c = log->counters();
    if (!log->io_error().empty()) {  // a truncated or corrupt file is never taken as complete
      throw Error(path + ": reading stopped after " + std::to_string(c.frames) + " frames: " + log->io_error());
    }
    r.source.frames += c.frames;
    r.source.malformed += c.malformed;
    r.source.error_frames += c.error_frames;
    r.source.time_backwards += c.time_backwards;
  }
  const uint64_t spikes = p.time_base().counters().spikes_dropped;
  p.Finish();
  r.clock_held_at_end = p.time_base().counters().spikes_dropped != spikes;
  r.first_frame_ns = watch.head.empty() ? -1 : watch.head.front();
  r.head_steady = watch.Steady();
  pipeline::Capture(p, r);
  return r;
}

nlohmann::json IdentifyReduced(const config::Config& config, const dbc::Database& db,
                               std::vector<pipeline::LogReduction> reductions) {
  const auto t0 = std::chrono::steady_clock::now();
  // Runs of logs that continue cleanly from each other; a log that does not is read again
  // together with the run before it (and the run extended until the next one continues cleanly).
  std::vector<pipeline::LogReduction> runs;
  for (size_t i = 0; i < reductions.size(); ++i) {
    if (runs.empty() || pipeline::ContinuesCleanly(runs.back(), reductions[i], config, nullptr)) {
      runs.push_back(std::move(reductions[i]));
      continue;
    }
    std::vector<std::string> logs = runs.back().logs;
    logs.insert(logs.end(), reductions[i].logs.begin(), reductions[i].logs.end());
    runs.back() = ReduceLogs(config, db, logs);
  }
  pipeline::Pipeline p(config, db);
  ReplayOutcome out;
  gate::GateCounters gate;
  int64_t drive_offset = 0;
  std::vector<std::string> all_logs;
  nlohmann::json run_logs = nlohmann::json::array();
  for (const pipeline::LogReduction& r : runs) {
    pipeline::AppendReduction(p, r, drive_offset, config);
    drive_offset += static_cast<int64_t>(r.gate.drives);
    for (size_t v = 0; v < gate.by_verdict.size(); ++v) gate.by_verdict[v] += r.gate.by_verdict[v];
    gate.drives += r.gate.drives;
    out.source.frames += r.source.frames;
    out.source.malformed += r.source.malformed;
    all_logs.insert(all_logs.end(), r.logs.begin(), r.logs.end());
    run_logs.push_back(r.logs);
  }
  if (!p.accumulator().window().empty()) p.IdentifyNow(true);  // the final fit, as replay --final-only
  out.history = p.history();
  if (!out.history.empty()) out.final_estimate = out.history.back();
  out.truth_eg = TruthBesideLogs(all_logs);
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::json j = ReplayDocument(p, out, gate);
  j["runs"] = std::move(run_logs);
  return j;
}

}  // namespace ndsid::desk
