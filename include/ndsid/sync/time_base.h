// Frame timestamps as a logger's clock gives them, made usable (docs/reliability.md, "Clocks
// that jump"). Loggers' clocks jump: an RTC reset, an NTP step, GPS time acquired, a single
// corrupt stamp. Rules, applied to every frame before the sync stage:
//   - a jump of more than kJump (forward or back) is held until kConfirm more frames show
//     where time goes on;
//   - a spike (the frames after the jump return to the old time base) is dropped and counted;
//     so one frame stamped years ahead never becomes the data time, nor is it persisted;
//   - a step back (the frames after it stay on the earlier base) starts a new time base: the
//     frames are shifted to continue after the last time plus `new_base_gap` (the pipeline
//     takes a gap longer than the sync stage fills and shorter than a drive gap: the drive goes
//     on, its segment is cut), nothing after the step is lost;
//   - a step forward (confirmed) is a gap in the data, kept as it is (the gate's drive-gap rule
//     applies).
// Backward jitter up to kJump between buses of one log is normal and passed through (the sync
// stage orders values per role). O(1) per frame; at most kConfirm + 1 frames held.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "ndsid/can/can_frame.h"

namespace ndsid::sync {

struct TimeBaseCounters {
  uint64_t spikes_dropped = 0;  // frames dropped as single-frame (or few-frame) time spikes
  uint64_t steps_back = 0;      // confirmed steps back: a new time base each
  uint64_t steps_forward = 0;   // confirmed jumps forward (gaps)
  int64_t shift_ns = 0;         // the current shift added to the frames' stamps (steps back)
};

class TimeBase {
 public:
  static constexpr int64_t kJump = 1'000'000'000;  // 1 s
  static constexpr int kConfirm = 3;                // frames that confirm a jump

  explicit TimeBase(int64_t new_base_gap_ns = 2'000'000'000) : new_base_gap_ns_(new_base_gap_ns) {}

  // Appends the frames that may go on (0, 1 or several, with corrected stamps) to `out`.
  void Push(const can::CanFrame& frame, std::vector<can::CanFrame>& out);
  // End of data: frames still held after a jump are dropped as a spike (too few to confirm it).
  void Finish();

  const TimeBaseCounters& counters() const noexcept { return counters_; }

 private:
  int64_t new_base_gap_ns_;
  bool started_ = false;
  int64_t last_ns_ = 0;  // last passed stamp, raw (before the shift)
  std::array<can::CanFrame, kConfirm + 1> held_{};
  int held_n_ = 0;
  TimeBaseCounters counters_;
};

}  // namespace ndsid::sync
