#include "ndsid/sync/time_base.h"

#include <cstdlib>

namespace ndsid::sync {
namespace {

bool Near(int64_t a, int64_t b) {
  const int64_t d = a - b;
  return d <= TimeBase::kJump && d >= -TimeBase::kJump;
}

}  // namespace

void TimeBase::Push(const can::CanFrame& frame, std::vector<can::CanFrame>& out) {
  auto pass = [&](can::CanFrame f) {
    last_ns_ = f.timestamp_ns;
    f.timestamp_ns += counters_.shift_ns;
    out.push_back(f);
  };
  const int64_t t = frame.timestamp_ns;
  if (!started_) {
    started_ = true;
    pass(frame);
    return;
  }
  if (held_n_ == 0) {
    if (Near(t, last_ns_)) {
      pass(frame);
    } else {
      held_[static_cast<size_t>(held_n_++)] = frame;  // a jump: wait for the frames after it
    }
    return;
  }
  const int64_t jumped = held_[0].timestamp_ns;
  if (Near(t, last_ns_)) {
    // Back on the old time base: the held frames were a spike.
    counters_.spikes_dropped += static_cast<uint64_t>(held_n_);
    held_n_ = 0;
    pass(frame);
    return;
  }
  if (!Near(t, jumped)) {
    // Neither base: treat this one as the start of the jump instead (the earlier held frames
    // were a spike of their own).
    counters_.spikes_dropped += static_cast<uint64_t>(held_n_);
    held_n_ = 0;
    held_[static_cast<size_t>(held_n_++)] = frame;
    return;
  }
  held_[static_cast<size_t>(held_n_++)] = frame;
  if (held_n_ <= kConfirm) return;
  // Confirmed: time goes on from the jumped stamp.
  if (jumped < last_ns_) {
    // A step back: shift the new base to continue after the old one, past a drive gap.
    counters_.shift_ns += (last_ns_ - jumped) + new_base_gap_ns_;
    ++counters_.steps_back;
  } else {
    ++counters_.steps_forward;
  }
  const int n = held_n_;
  held_n_ = 0;
  for (int i = 0; i < n; ++i) pass(held_[static_cast<size_t>(i)]);
}

void TimeBase::Finish() {
  counters_.spikes_dropped += static_cast<uint64_t>(held_n_);
  held_n_ = 0;
}

}  // namespace ndsid::sync
