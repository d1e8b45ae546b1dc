#include "ndsid/common/closest_match.h"

#include <gtest/gtest.h>

namespace ndsid {
namespace {

TEST(EditDistance, CountsInsertionsDeletionsAndSubstitutions) {
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3u);
  EXPECT_EQ(EditDistance("", "abc"), 3u);
  EXPECT_EQ(EditDistance("abc", ""), 3u);
  EXPECT_EQ(EditDistance("wheelbase_m", "wheelbse_m"), 1u);
  EXPECT_EQ(EditDistance("KM/H", "km/h"), 0u);  // case-insensitive
}

TEST(ClosestMatch, PicksTheNearestAcceptedWordOrNothing) {
  const std::vector<std::string> units{"km/h", "kph", "m/s", "mph"};
  EXPECT_EQ(ClosestMatch("km/hr", units), "km/h");
  EXPECT_EQ(ClosestMatch("MPH", units), "mph");
  EXPECT_EQ(ClosestMatch("furlongs/fortnight", units), "");
  const std::vector<std::string> keys{"name", "wheelbase_m", "mass_kg"};
  EXPECT_EQ(ClosestMatch("wheelbase", keys), "wheelbase_m");  // contained
  EXPECT_EQ(ClosestMatch("mass", keys), "mass_kg");
  EXPECT_EQ(ClosestMatch("colour", keys), "");
}

TEST(AcceptedValuesHint, ListsTheAcceptedValuesAndTheClosest) {
  EXPECT_EQ(AcceptedValuesHint("deg/sec", {"deg/s", "rad/s"}), "; did you mean 'deg/s'? (accepted: deg/s, rad/s)");
  EXPECT_EQ(AcceptedValuesHint("xyz", {"deg", "rad"}), " (accepted: deg, rad)");
  EXPECT_EQ(AcceptedValuesHint("xyz", {}), "");
}

}  // namespace
}  // namespace ndsid
