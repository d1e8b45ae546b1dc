// At most `rate_hz` messages per second of wall-clock (monotonic) time, whatever the data rate:
// a fast replay produces data hours per wall second, and a live view needs no more than it can
// draw. The first message passes; each later one passes when a full period has elapsed since
// the last one that passed.
#pragma once

#include <cstdint>

namespace ndsid::publish {

class WallRateLimiter {
 public:
  explicit WallRateLimiter(double rate_hz) : period_ns_(rate_hz > 0 ? static_cast<int64_t>(1e9 / rate_hz) : 0) {}

  // `now_ns`: a monotonic clock (steady_clock in the daemon, any in tests).
  bool Allow(int64_t now_ns) noexcept {
    if (passed_ && now_ns - last_ns_ < period_ns_) {
      ++suppressed_;
      return false;
    }
    passed_ = true;
    last_ns_ = now_ns;
    return true;
  }
  uint64_t suppressed() const noexcept { return suppressed_; }

 private:
  int64_t period_ns_;
  int64_t last_ns_ = 0;
  bool passed_ = false;
  uint64_t suppressed_ = 0;
};

}  // namespace ndsid::publish
