// TimeBase (docs/reliability.md, "Clocks that jump"): spikes dropped, steps back rebased, gaps
// kept, jitter passed, on synthetic 100 Hz streams of two interleaved buses.
#include "ndsid/sync/time_base.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace ndsid::sync {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kYear = 365LL * 24 * 3600 * 1'000'000'000;

can::CanFrame At(int64_t t_ns, uint32_t id = 0x100) {
  can::CanFrame f;
  f.timestamp_ns = t_ns;
  f.id = id;
  f.len = 8;
  return f;
}

struct Stream {
  TimeBase tb;
  std::vector<can::CanFrame> out;
  void Push(int64_t t, uint32_t id = 0x100) { tb.Push(At(t, id), out); }
  bool Monotonic(int64_t tolerance_ns) const {
    for (size_t i = 1; i < out.size(); ++i)
      if (out[i].timestamp_ns < out[i - 1].timestamp_ns - tolerance_ns) return false;
    return true;
  }
};

// Catches: one frame stamped 10 years ahead becoming the data time, or a
// spike back dropping the frames after it.
TEST(TimeBase, SpikesAreDroppedAndCounted) {
  for (int64_t spike : {10 * kYear, -3600'000 * kMs, 5'000 * kMs}) {
    Stream r;
    for (int k = 0; k < 1000; ++k) {
      r.Push(1000 * kMs + k * 10 * kMs);
      if (k == 500) r.Push(1000 * kMs + k * 10 * kMs + spike, 0x200);
    }
    r.tb.Finish();
    EXPECT_EQ(r.out.size(), 1000u) << spike;
    EXPECT_EQ(r.tb.counters().spikes_dropped, 1u);
    EXPECT_EQ(r.tb.counters().steps_back + r.tb.counters().steps_forward, 0u);
    EXPECT_LT(r.out.back().timestamp_ns, 1000 * kMs + 1000 * 10 * kMs) << "no future stamp went through";
    EXPECT_TRUE(r.Monotonic(0));
  }
  // Two frames of a spike, then back: both dropped.
  Stream r;
  for (int k = 0; k < 100; ++k) {
    r.Push(k * 10 * kMs);
    if (k == 50) r.Push(kYear), r.Push(kYear + kMs);
  }
  EXPECT_EQ(r.tb.counters().spikes_dropped, 2u);
  EXPECT_EQ(r.out.size(), 100u);
}

// Catches: a clock stepped back by an hour silently discarding everything after the step (a
// replay reading "1 drives, 0.000 gated h"); the new base must continue after the old one, past a drive gap.
TEST(TimeBase, StepBackStartsANewTimeBaseAndLosesNothing) {
  Stream r;
  const int64_t t0 = 7200'000 * kMs;
  for (int k = 0; k < 500; ++k) r.Push(t0 + k * 10 * kMs);
  const int64_t last_before = r.out.back().timestamp_ns;
  for (int k = 0; k < 500; ++k) r.Push(t0 - 3600'000 * kMs + k * 10 * kMs);  // stepped back 1 h
  r.tb.Finish();
  ASSERT_EQ(r.out.size(), 1000u);
  EXPECT_EQ(r.tb.counters().steps_back, 1u);
  EXPECT_EQ(r.tb.counters().spikes_dropped, 0u);
  EXPECT_TRUE(r.Monotonic(0));
  EXPECT_EQ(r.out[500].timestamp_ns - last_before, 2'000'000'000) << "the default new-base gap";
  // Spacing within the new base is kept.
  EXPECT_EQ(r.out[700].timestamp_ns - r.out[600].timestamp_ns, 100 * 10 * kMs);
  // A second step back shifts again.
  Stream two;
  for (int s = 0; s < 3; ++s)
    for (int k = 0; k < 100; ++k) two.Push(10'000'000 * kMs - s * 3'000'000 * kMs + k * 10 * kMs);
  EXPECT_EQ(two.tb.counters().steps_back, 2u);
  EXPECT_EQ(two.out.size(), 300u);
  EXPECT_TRUE(two.Monotonic(0));
}

// Catches: a real gap (logs of two days concatenated) taken for a spike, or bus jitter rejected.
TEST(TimeBase, ForwardGapsAndJitterPass) {
  Stream r;
  for (int k = 0; k < 300; ++k) {
    r.Push(k * 10 * kMs, 0x100);
    r.Push(k * 10 * kMs - 20 * kMs, 0x200);  // the other bus's frames stamped up to 20 ms earlier
  }
  for (int k = 0; k < 300; ++k) r.Push(8 * 3600'000 * kMs + k * 10 * kMs);  // 8 h later
  r.tb.Finish();
  EXPECT_EQ(r.out.size(), 900u);
  EXPECT_EQ(r.tb.counters().steps_forward, 1u);
  EXPECT_EQ(r.tb.counters().spikes_dropped, 0u);
  EXPECT_EQ(r.tb.counters().shift_ns, 0);
  EXPECT_EQ(r.out.back().timestamp_ns, 8 * 3600'000 * kMs + 299 * 10 * kMs) << "a gap is kept as it is";
}

// Catches: frames held after a jump at the end of the data being passed unconfirmed.
TEST(TimeBase, UnconfirmedJumpAtTheEndIsDropped) {
  Stream r;
  for (int k = 0; k < 100; ++k) r.Push(k * 10 * kMs);
  r.Push(kYear);
  r.Push(kYear + 10 * kMs);
  r.tb.Finish();
  EXPECT_EQ(r.out.size(), 100u);
  EXPECT_EQ(r.tb.counters().spikes_dropped, 2u);
}

}  // namespace
}  // namespace ndsid::sync
