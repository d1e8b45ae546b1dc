// A stretch of logs read alone by a fresh pipeline (a fleet's per-log task, docs/fleet.md):
// what it learned, read to its end, in a form that merges. A vehicle's logs are reduced one by
// one, in parallel, and appended in order to one pipeline (AppendReduction), which then holds
// the window, the drives, the statistics and the evidence one pipeline reading the logs in
// order holds — provided each log begins as that pipeline would have continued
// (ContinuesCleanly: a new drive, the sync stage and the clock restarting as they would have).
// Where a log does not, it is reduced together with the one before it (the desk's
// fleet_reduce.h does both).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ndsid/adequacy/plausibility.h"
#include "ndsid/can/frame_source.h"
#include "ndsid/common/json_codec.h"
#include "ndsid/config/config.h"
#include "ndsid/gate/gate.h"
#include "ndsid/pipeline/pipeline.h"
#include "ndsid/sync/time_base.h"

namespace ndsid::pipeline {

struct LogReduction {
  std::vector<std::string> logs;  // the logs, in the order they were read
  // --- What the pipeline learned (Capture) ---
  nlohmann::json accumulator;               // stats::Accumulator::ToJson(), no segment evicted
  std::string window_steps;                 // stats::Accumulator::window_steps()
  std::vector<gate::StandstillStop> stops;  // standstills, numbered by the accumulator's drives
  std::map<int64_t, adequacy::SpeedSums> wheel_speed;  // wheel-speed sums per drive
  gate::GateCounters gate;                  // verdict counts and the drives the gate started
  sync::TimeBaseCounters clock;             // the clock's faults
  int64_t data_time_ns = 0;                 // newest frame time (Pipeline::data_time_ns)
  // --- The reading (filled by whoever read the logs) ---
  can::SourceCounters source;      // summed over the logs
  bool clock_held_at_end = false;  // frames held after a clock jump were dropped at the end
  int64_t first_frame_ns = -1;     // time stamp of the first frame
  // The first TimeBase::kConfirm + 1 frames each lie within TimeBase::kJump of the first
  // frame and of the one before: a clock jump before them is confirmed by them unchanged.
  bool head_steady = false;
  int64_t sync_start_frame_ns = -1;  // time stamp of the frame whose value started the sync stage
  bool sync_start_exact = false;     // that frame passed the clock stage unchanged, nothing held
  int64_t first_sample_ns = -1;      // the sync stage's first and last sample (-1: none)
  int64_t last_sample_ns = -1;
};

// The learned part of a pipeline that has read its logs to the end (Finish() called) from a
// start with stats::Accumulator::RecordWindowSteps() on.
void Capture(const Pipeline& pipeline, LogReduction& reduction);

// Whether `next` begins as one pipeline that had read `before` would have continued into it:
// the clock not shifted nor holding frames at the end of `before`; a silence before `next`
// longer than the clock's jump, the sync stage's fill gap and timeouts and the gate's drive
// gap (a new drive); `next`'s clock confirming its first frames unchanged and its sync grid
// starting where the continued one would restart it. Else `why` says which rule failed.
bool ContinuesCleanly(const LogReduction& before, const LogReduction& next, const config::Config& config,
                      std::string* why);

// Appends `reduction` to `merged` (a pipeline of the same configuration holding the
// reductions before it, all finished): the accumulator (stats::Accumulator::Append), the
// standstills and wheel-speed sums with their drives renumbered by drive_offset (the drives the
// gate started before it), the newest frame time. Throws Error/CodecError on a reduction
// that does not fit.
void AppendReduction(Pipeline& merged, const LogReduction& reduction, int64_t drive_offset, const config::Config& config);

// The reduction as a document (CBOR carries it between processes), and back, checked.
nlohmann::json LogReductionToJson(const LogReduction& r);
LogReduction LogReductionFromJson(const JsonIn& in);

}  // namespace ndsid::pipeline
