// The held-out drives of a window (stats/held_out.h), the rule the pipeline's snapshots use.
#include "ndsid/stats/held_out.h"

#include <gtest/gtest.h>

namespace ndsid::stats {
namespace {

std::shared_ptr<const Segment> Seg(int64_t drive, size_t samples) {
  auto s = std::make_shared<Segment>();
  s->drive_id = drive;
  s->dt_s = 0.01;
  s->samples.resize(samples);
  return s;
}

TEST(HeldOutDrives, EveryKthDriveWhenTheWindowHasOne) {
  std::deque<std::shared_ptr<const Segment>> w;
  for (int64_t d = 0; d < 12; ++d) w.push_back(Seg(d, 100 + static_cast<size_t>(d)));
  w.push_back(Seg(4, 50));  // a drive's second segment
  // validation_fraction 0.2: k = 5, drives 4 and 9.
  EXPECT_EQ(HeldOutDrives(w, 0.2), (std::set<int64_t>{4, 9}));
  // 0.3: k = round(3.33) = 3, drives 2, 5, 8, 11.
  EXPECT_EQ(HeldOutDrives(w, 0.3), (std::set<int64_t>{2, 5, 8, 11}));
  // At least every second drive, even for a fraction above one half.
  EXPECT_EQ(HeldOutDrives(w, 0.9), (std::set<int64_t>{1, 3, 5, 7, 9, 11}));
}

TEST(HeldOutDrives, TheShortestDriveWhileNoKthDriveIsInTheWindow) {
  std::deque<std::shared_ptr<const Segment>> w;
  w.push_back(Seg(10, 300));
  w.push_back(Seg(11, 200));
  w.push_back(Seg(12, 150));
  w.push_back(Seg(10, 100));  // drive 10 totals 400 samples
  w.push_back(Seg(13, 250));
  EXPECT_EQ(HeldOutDrives(w, 0.2), (std::set<int64_t>{12}));  // none of 10..13 is 4 mod 5
  w.push_back(Seg(14, 1000));
  EXPECT_EQ(HeldOutDrives(w, 0.2), (std::set<int64_t>{14}));  // the regular rule again
}

TEST(HeldOutDrives, NoneForOneDriveOrWithoutValidation) {
  std::deque<std::shared_ptr<const Segment>> w;
  EXPECT_TRUE(HeldOutDrives(w, 0.2).empty());
  w.push_back(Seg(3, 100));
  w.push_back(Seg(3, 100));
  EXPECT_TRUE(HeldOutDrives(w, 0.2).empty());  // a single drive: it trains
  w.push_back(Seg(4, 100));
  EXPECT_TRUE(HeldOutDrives(w, 0.0).empty());
  EXPECT_TRUE(HeldOutDrives(w, -1.0).empty());
  EXPECT_EQ(HeldOutDrives(w, 0.2), (std::set<int64_t>{4}));
}

}  // namespace
}  // namespace ndsid::stats
