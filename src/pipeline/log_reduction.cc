#include "ndsid/pipeline/log_reduction.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "ndsid/common/error.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "ndsid/stats/accumulator.h"

namespace ndsid::pipeline {
namespace {

constexpr size_t kMaxLogs = 1'000'000;      // logs in one reduction
constexpr size_t kMaxDrives = size_t{1} << 22;  // drives with wheel-speed sums

int64_t Ns(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

// The silence before a log after which nothing of the one before reaches into it: past the
// clock's jump (the first frame is held and confirmed), the sync stage's fill gap, every
// role's and validity flag's timeout and the latencies (the held values are stale, the grid
// restarts), and the gate's drive gap (a new drive).
int64_t CleanGapNs(const config::Config& c) {
  double timeouts_s = 0, shift_s = 0;
  for (const auto& r : c.roles) {
    if (!r) continue;
    timeouts_s = std::max(timeouts_s, r->timeout_s);
    shift_s = std::max(shift_s, std::abs(r->latency_s));
  }
  for (const auto& v : c.validity) timeouts_s = std::max(timeouts_s, v.timeout_s);
  const double gap_s = std::max({c.gate.drive_gap_s, c.sync.max_fill_gap_s, timeouts_s});
  return sync::TimeBase::kJump + Ns(gap_s + shift_s + std::abs(c.sync.latency_s));
}

nlohmann::json GateJson(const gate::GateCounters& g) {
  nlohmann::json by = nlohmann::json::array();
  for (const uint64_t n : g.by_verdict) by.push_back(n);
  return {{"by_verdict", by}, {"drives", g.drives}};
}

gate::GateCounters GateFromJson(const JsonIn& in) {
  gate::GateCounters g;
  const JsonIn by = in.At("by_verdict");
  if (by.Size(gate::kNumVerdicts) != gate::kNumVerdicts) by.Fail("needs one count per verdict");
  for (size_t i = 0; i < g.by_verdict.size(); ++i) g.by_verdict[i] = by.At(i).UInt64();
  g.drives = in.UInt64("drives");
  return g;
}

}  // namespace

void Capture(const Pipeline& pipeline, LogReduction& r) {
  const stats::Accumulator& acc = pipeline.accumulator();
  r.accumulator = acc.ToJson();
  r.window_steps = acc.window_steps();
  r.stops.assign(pipeline.stops().begin(), pipeline.stops().end());
  r.wheel_speed = pipeline.wheel_speed();
  r.gate = pipeline.gate().counters();
  r.clock = pipeline.time_base().counters();
  r.data_time_ns = pipeline.data_time_ns();
}

bool ContinuesCleanly(const LogReduction& before, const LogReduction& next, const config::Config& config, std::string* why) {
  auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  if (before.first_sample_ns < 0 || next.first_sample_ns < 0) return fail("a log without synchronised samples");
  if (before.clock.shift_ns != 0) return fail("the clock stepped back before it (its time stamps are shifted)");
  if (before.clock_held_at_end) return fail("the log before it ends in a clock jump");
  const int64_t gap_ns = next.first_frame_ns - before.data_time_ns;
  if (gap_ns <= CleanGapNs(config))
    return fail("it begins " + std::to_string(1e-9 * static_cast<double>(gap_ns)) + " s after the log before it, within a drive");
  if (!next.head_steady) return fail("its first frames jump in time");
  if (next.sync_start_frame_ns < 0 || !next.sync_start_exact) return fail("its first values came after a clock jump");
  const int64_t period_ns = std::llround(1e9 / config.sync.rate_hz);
  if (next.first_sample_ns != (next.sync_start_frame_ns / period_ns + 1) * period_ns)
    return fail("its sync grid starts elsewhere than a continued reading restarts it");
  return true;
}

void AppendReduction(Pipeline& merged, const LogReduction& r, int64_t drive_offset, const config::Config& config) {
  stats::Accumulator later(config, config.sync.rate_hz);
  later.RecordWindowSteps();
  later.FromJson(JsonIn(r.accumulator, "reduction.accumulator"));
  merged.mutable_accumulator().Append(later, r.window_steps, drive_offset);
  std::vector<gate::StandstillStop> stops(merged.stops().begin(), merged.stops().end());
  for (gate::StandstillStop st : r.stops) {
    st.drive_id += drive_offset;
    stops.push_back(st);
  }
  merged.RestoreStops(stops);
  std::map<int64_t, adequacy::SpeedSums> wheel = merged.wheel_speed();
  for (const auto& [drive, sums] : r.wheel_speed) wheel[drive + drive_offset] = sums;
  merged.RestoreEvidence(std::move(wheel), std::max(merged.data_time_ns(), r.data_time_ns));
}

nlohmann::json LogReductionToJson(const LogReduction& r) {
  nlohmann::json j;
  j["logs"] = r.logs;
  j["accumulator"] = r.accumulator;
  j["window_steps"] = r.window_steps;
  j["stops"] = StopsToJson(r.stops);
  nlohmann::json wheel = nlohmann::json::array();
  for (const auto& [drive, s] : r.wheel_speed) {
    wheel.push_back({{"drive", drive}, {"sww", s.sww}, {"svw", s.svw}, {"svv", s.svv}, {"seconds", s.seconds}, {"t0_ns", s.t0_ns}});
  }
  j["wheel_speed"] = std::move(wheel);
  j["gate"] = GateJson(r.gate);
  j["clock"] = {{"spikes_dropped", r.clock.spikes_dropped}, {"steps_back", r.clock.steps_back},
                {"steps_forward", r.clock.steps_forward}, {"shift_ns", r.clock.shift_ns}, {"held_at_end", r.clock_held_at_end}};
  j["data_time_ns"] = r.data_time_ns;
  j["source"] = {{"frames", r.source.frames}, {"malformed", r.source.malformed}, {"error_frames", r.source.error_frames},
                 {"time_backwards", r.source.time_backwards}};
  j["start"] = {{"first_frame_ns", r.first_frame_ns}, {"head_steady", r.head_steady},
                {"sync_start_frame_ns", r.sync_start_frame_ns}, {"sync_start_exact", r.sync_start_exact},
                {"first_sample_ns", r.first_sample_ns}, {"last_sample_ns", r.last_sample_ns}};
  return j;
}

LogReduction LogReductionFromJson(const JsonIn& in) {
  LogReduction r;
  r.logs = in.At("logs").Strings(kMaxLogs);
  r.accumulator = in.At("accumulator").raw();
  r.window_steps = in.String("window_steps");
  r.stops = StopsFromJson(in.At("stops"), Pipeline::kMaxStops);
  const JsonIn wheel = in.At("wheel_speed");
  const size_t n = wheel.Size(kMaxDrives);
  for (size_t i = 0; i < n; ++i) {
    const JsonIn w = wheel.At(i);
    adequacy::SpeedSums s;
    s.sww = w.Finite("sww");
    s.svw = w.Finite("svw");
    s.svv = w.Finite("svv");
    s.seconds = w.Finite("seconds");
    s.t0_ns = w.Int64("t0_ns");
    if (s.sww < 0 || s.svv < 0 || s.seconds < 0) w.Fail("negative sums");
    r.wheel_speed[w.Int64("drive")] = s;
  }
  r.gate = GateFromJson(in.At("gate"));
  const JsonIn clock = in.At("clock");
  r.clock.spikes_dropped = clock.UInt64("spikes_dropped");
  r.clock.steps_back = clock.UInt64("steps_back");
  r.clock.steps_forward = clock.UInt64("steps_forward");
  r.clock.shift_ns = clock.Int64("shift_ns");
  r.clock_held_at_end = clock.Bool("held_at_end");
  r.data_time_ns = in.Int64("data_time_ns");
  const JsonIn source = in.At("source");
  r.source.frames = source.UInt64("frames");
  r.source.malformed = source.UInt64("malformed");
  r.source.error_frames = source.UInt64("error_frames");
  r.source.time_backwards = source.UInt64("time_backwards");
  const JsonIn start = in.At("start");
  r.first_frame_ns = start.Int64("first_frame_ns");
  r.head_steady = start.Bool("head_steady");
  r.sync_start_frame_ns = start.Int64("sync_start_frame_ns");
  r.sync_start_exact = start.Bool("sync_start_exact");
  r.first_sample_ns = start.Int64("first_sample_ns");
  r.last_sample_ns = start.Int64("last_sample_ns");
  return r;
}

}  // namespace ndsid::pipeline
