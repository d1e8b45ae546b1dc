#include "ndsid/common/closest_match.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cstdint>

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

// ClosestMatch skips the edit-distance table where the length gap already decides; it must choose
// what the full table would, here over every pair of a mixed word list (typos, prefixes, case).
TEST(ClosestMatch, TheLengthShortcutChoosesWhatTheFullDistanceWould) {
  const std::vector<std::string> words{"a", "ab", "abc", "wheelbase", "wheelbase_m", "WHEELBASE_M", "wheel",
                                       "whelbase_m", "mass_kg", "mass", "m", "km/h", "kmh", "gyro_offset",
                                       "gyro", "offset", "steer_offset", "road_bank", "bank", "xyzzy", ""};
  for (const std::string& w : words) {
    std::string expected;
    size_t best = SIZE_MAX;
    for (const std::string& c : words) {
      const size_t d = EditDistance(w, c);
      const size_t limit = std::clamp<size_t>(std::max(w.size(), c.size()) / 3, 1, 3);
      std::string lw = w, lc = c;
      for (char& ch : lw) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      for (char& ch : lc) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      const bool contains = !lw.empty() && !lc.empty() && (lc.find(lw) != std::string::npos || lw.find(lc) != std::string::npos);
      if ((d <= limit || contains) && d < best) expected = c, best = d;
    }
    EXPECT_EQ(ClosestMatch(w, words), expected) << "word '" << w << "'";
  }
  // A long unknown key still gets its hint, by containment.
  const std::string long_key = std::string(5000, 'x') + "wheelbase_m";
  EXPECT_EQ(ClosestMatch(long_key, {"mass_kg", "wheelbase_m"}), "wheelbase_m");
  EXPECT_EQ(ClosestMatch(std::string(5000, 'x'), {"mass_kg", "wheelbase_m"}), "");
}

TEST(AcceptedValuesHint, ListsTheAcceptedValuesAndTheClosest) {
  EXPECT_EQ(AcceptedValuesHint("deg/sec", {"deg/s", "rad/s"}), "; did you mean 'deg/s'? (accepted: deg/s, rad/s)");
  EXPECT_EQ(AcceptedValuesHint("xyz", {"deg", "rad"}), " (accepted: deg, rad)");
  EXPECT_EQ(AcceptedValuesHint("xyz", {}), "");
}

}  // namespace
}  // namespace ndsid
