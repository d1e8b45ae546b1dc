// Everything learned from gated samples: steady-state statistics, coverage, and the window of
// recent segments for the dynamic fit. Applies the study's drive rule: a drive's data are held
// back until it has covered min_drive_km, and discarded if it ends shorter.
#pragma once

#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "ndsid/common/json_codec.h"
#include "ndsid/config/config.h"
#include "ndsid/gate/gate.h"
#include "ndsid/stats/coverage.h"
#include "ndsid/stats/segment.h"
#include "ndsid/stats/steady_state.h"

namespace ndsid::stats {

struct DriveSummary {
  int64_t drive_id = 0;
  int64_t start_ns = 0;
  int64_t end_ns = 0;
  double distance_km = 0;
  double gated_s = 0;   // accepted time
  bool used = false;    // passed the min_drive_km rule
};

struct AccumulatorCounters {
  uint64_t short_drive_samples = 0;   // accepted samples discarded because their drive was < min_drive_km
  uint64_t short_segment_samples = 0; // accepted samples in stretches shorter than min_segment_s
  uint64_t evicted_segments = 0;      // segments dropped from the window (older than window_h)
};

class Accumulator {
 public:
  Accumulator(const config::Config& config, double sync_rate_hz);

  void Add(const gate::GatedSample& g);
  void Finish();  // end of data: close the current segment and drive

  const SteadyStateStats& steady_state() const { return steady_; }
  const Coverage& coverage() const { return coverage_; }
  // Shared, immutable segments: an identification running on another thread keeps its copy
  // of the list valid while the window moves on.
  const std::deque<std::shared_ptr<const Segment>>& window() const { return window_; }
  const std::vector<DriveSummary>& drives() const { return drives_; }
  double gated_hours() const { return gated_s_ / 3600.0; }  // accepted time of used drives
  double window_hours() const;
  const AccumulatorCounters& counters() const { return counters_; }

  // Persistence (the daemon's learned state, docs/state-format.md). ToJson() writes the learned
  // state without changing this object: statistics, drives, the window (each segment's samples
  // as little-endian float32 rows), and the drive in progress kept open, with its held-back
  // data when it is still short of min_drive_km, and its open segment. FromJson() replaces
  // everything learned with such a document, checks every value (finite, in range) and throws
  // CodecError naming the path of the first bad one, leaving this object unchanged. After a
  // restore the first drive the gate starts continues the restored open drive (same drive
  // number, its distance and held-back data) when its first sample comes within
  // gate.drive_gap_s of the drive's last one, as a drive would have gone on without the
  // restart, and the open segment goes on when that sample is accepted and not a segment
  // start; otherwise the open drive ends there (as Finish() would have ended it) and the new
  // drives are numbered after the restored ones.
  nlohmann::json ToJson() const;
  void FromJson(const JsonIn& in);
  // Samples up to this time are ignored: a log re-read after a restart from a few seconds
  // before its resume point (to warm up the sync stage and the gate) gives them again.
  void SkipThrough(int64_t t_ns) { skip_through_ns_ = t_ns; }
  // The time of the last sample added (0 before any).
  int64_t last_sample_ns() const { return drives_.empty() ? 0 : drives_.back().end_ns; }
  // The window's drive number of a drive number of the gate (they differ after a restore).
  int64_t DriveIdOf(int64_t gate_drive_id) const { return gate_drive_id + drive_id_offset_; }

  // --- Merging the accumulators of consecutive stretches of data (a fleet's per-log reduce,
  // pipeline/log_reduction.h) ---
  // From this call on, records how the window grows, one letter a step: 'a' a used drive's
  // segment closed (appended, then the window evicted beyond window_h), 'h' a held-back segment
  // closed (the window evicted), 'c' a held-back segment committed (appended, nothing evicted).
  // While recording nothing is evicted (FromJson() included): the window keeps every segment,
  // so that Append() can replay the steps on a longer history.
  void RecordWindowSteps() { record_steps_ = true; }
  const std::string& window_steps() const { return window_steps_; }
  // Continues this accumulator with `later`, learned by another accumulator from data that
  // follow this one's and begin with a new drive: both finished (no drive open), `later`
  // recorded from its start, `steps` its window_steps(). Its drives are renumbered by
  // drive_offset; drives, counters, statistics, coverage and gated time are added, and the
  // window grows step by step, evicting as CloseSegment() does: the window, drives and counters
  // one accumulator reading both in order would hold (the sums of the statistics and of the
  // gated time equal up to rounding). Throws Error when a precondition does not hold.
  void Append(const Accumulator& later, const std::string& steps, int64_t drive_offset);

 private:
  void CloseSegment();
  void CloseDrive();
  void CommitPending();
  void EvictBeyondWindow();  // drops the oldest segments while the rest still span window_h
  void RecordStep(char step) {
    if (record_steps_) window_steps_.push_back(step);
  }

  const config::Config& config_;
  int decimation_;
  double segment_dt_s_;
  size_t min_segment_samples_;
  double window_s_;

  SteadyStateStats steady_, pending_steady_;
  Coverage coverage_, pending_coverage_;
  std::deque<std::shared_ptr<const Segment>> window_;
  std::vector<std::shared_ptr<const Segment>> pending_segments_;
  std::vector<DriveSummary> drives_;
  double gated_s_ = 0, pending_gated_s_ = 0;
  uint64_t pending_samples_ = 0;
  bool drive_open_ = false;
  bool drive_used_ = false;

  Segment current_;
  bool segment_open_ = false;
  // Decimation accumulator.
  SegmentSample sum_{};
  int summed_ = 0;
  int64_t sum_t0_ns_ = 0;
  AccumulatorCounters counters_;
  int64_t drive_id_offset_ = 0;  // added to the gate's drive ids after a Restore()
  bool resume_open_ = false;     // restored with a drive open: the gate's next drive may continue it
  double distance_base_km_ = 0;  // a continued drive's distance before the restart
  int64_t skip_through_ns_ = std::numeric_limits<int64_t>::min();
  bool record_steps_ = false;  // RecordWindowSteps(): keep every segment, record the steps
  std::string window_steps_;   // the recorded steps ('a', 'h', 'c')
};

}  // namespace ndsid::stats
