#include "progress.h"

#include <gtest/gtest.h>

namespace ndsid::desk {
namespace {

TEST(ProgressLine, ShowsShareRatesAndTimeLeft) {
  // 25 % done after 10 s: 30 s left; 2.5 M frames in 10 s; 1 h of data in 10 s.
  const std::string line = FormatProgressLine("replay", 0.25, 2'500'000, 3600.0, 10.0);
  EXPECT_NE(line.find(" 25 %"), std::string::npos) << line;
  EXPECT_NE(line.find("0.25 M frames/s"), std::string::npos) << line;
  EXPECT_NE(line.find("0.10 data-h/s"), std::string::npos) << line;
  EXPECT_NE(line.find("ETA 0:30"), std::string::npos) << line;
}

TEST(ProgressLine, NoShareOrTimeLeftWhenUnknown) {
  const std::string line = FormatProgressLine("replay", -1, 1000, 10.0, 2.0);
  EXPECT_EQ(line.find('%'), std::string::npos) << line;
  EXPECT_EQ(line.find("ETA"), std::string::npos) << line;
  EXPECT_NE(line.find("frames/s"), std::string::npos) << line;
}

TEST(ProgressLine, MinutesAndSecondsOfLongRuns) {
  EXPECT_NE(FormatProgressLine("x", 0.1, 0, 0, 60.0).find("ETA 9:00"), std::string::npos);
}

}  // namespace
}  // namespace ndsid::desk
