#include "ndsid/publish/rate_limiter.h"

#include <gtest/gtest.h>

namespace ndsid::publish {
namespace {

// 10 Hz: of 1 000 offers spread evenly over one second, the first and one per 100 ms pass.
TEST(WallRateLimiter, PassesOnePerPeriodWhateverTheOfferRate) {
  WallRateLimiter limit(10);
  int passed = 0;
  for (int i = 0; i < 1000; ++i) passed += limit.Allow(int64_t{1'000'000} * i);  // every 1 ms
  EXPECT_EQ(passed, 10);
  EXPECT_EQ(limit.suppressed(), 990u);
}

TEST(WallRateLimiter, SlowerOffersAllPass) {
  WallRateLimiter limit(10);
  for (int i = 0; i < 50; ++i) EXPECT_TRUE(limit.Allow(int64_t{250'000'000} * i)) << i;  // 4 Hz
  EXPECT_EQ(limit.suppressed(), 0u);
}

TEST(WallRateLimiter, FirstMessagePassesAtAnyClockValue) {
  WallRateLimiter limit(1);
  EXPECT_TRUE(limit.Allow(-5));
  EXPECT_FALSE(limit.Allow(0));
  EXPECT_TRUE(limit.Allow(1'000'000'000));
}

}  // namespace
}  // namespace ndsid::publish
