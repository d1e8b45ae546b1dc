// Limits and undefined behaviour found by fuzzing and by hand (docs/reliability.md):
// integers at the ends of int64, numbers that do not fit, and the overlap check on messages
// with tens of thousands of signals. Each test names what it would catch.
#include <gtest/gtest.h>

#include <string>

#include "ndsid/dbc/dbc_parser.h"

namespace ndsid::dbc {
namespace {

constexpr const char* kMessage = "BO_ 1 M: 8 ECU\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" ECU\n";

// Catches: INT64_MAX parsed through a double (2^63 after rounding) and rejected, or its
// float-to-integer conversion overflowing (undefined behaviour under UBSan).
TEST(DbcLimits, ValueTableTakesBothEndsOfInt64) {
  const Database db = ParseDbcText(std::string(kMessage) +
                                       "VAL_ 1 S 9223372036854775807 \"max\" -9223372036854775808 \"min\" 3 \"three\";\n",
                                   "t.dbc");
  const auto& table = db.messages.at(0).signals.at(0).value_table;
  ASSERT_EQ(table.size(), 3u);
  EXPECT_EQ(table.at(INT64_MAX), "max");
  EXPECT_EQ(table.at(INT64_MIN), "min");
  EXPECT_EQ(table.at(3), "three");
}

// Catches: a value written as a float beyond int64 cast to int64 (UB) instead of a located error.
TEST(DbcLimits, IntegerBeyondInt64IsALocatedError) {
  for (const char* value : {"1e300", "9223372036854775808", "-9.3e18", "1.5"}) {
    try {
      ParseDbcText(std::string(kMessage) + "VAL_ 1 S " + value + " \"x\";\n", "t.dbc");
      ADD_FAILURE() << value << " accepted";
    } catch (const DbcError& e) {
      EXPECT_EQ(e.line(), 3) << value;
      EXPECT_EQ(e.column(), 10) << value;
      EXPECT_NE(std::string(e.what()).find("integer"), std::string::npos) << e.what();
    }
  }
  // Integral floats inside the range are still integers.
  const Database db = ParseDbcText(std::string(kMessage) + "VAL_ 1 S 4.0 \"four\" 1e3 \"k\";\n", "t.dbc");
  EXPECT_EQ(db.messages.at(0).signals.at(0).value_table.at(1000), "k");
}

// Catches: SIG_VALTYPE_ 4294967297 narrowed to int (1, float32) before the range check.
TEST(DbcLimits, ValueTypeIsCheckedBeforeNarrowing) {
  EXPECT_THROW(ParseDbcText("BO_ 1 M: 8 ECU\n SG_ F : 0|32@1- (1,0) [0|0] \"\" ECU\nSIG_VALTYPE_ 1 F : 4294967297;\n", "t.dbc"),
               DbcError);
}

std::string ManySignals(int n, int bits_each) {
  std::string text = "BO_ 1 WIDE: 64 ECU\n";
  for (int i = 0; i < n; ++i) {
    text += " SG_ S" + std::to_string(i) + " : " + std::to_string((i * bits_each) % 512) + "|" +
            std::to_string(bits_each) + "@1+ (1,0) [0|0] \"\" ECU\n";
  }
  return text;
}

// Catches: the pairwise overlap check (4 000 signals took 2 GB and 21 s, 50 000 exhausted
// 24 GB): 50 000 signals sharing 64 bytes load, each overlapping signal is reported once, and
// the warnings stop at 100 per message plus one line counting the rest.
TEST(DbcLimits, FiftyThousandOverlappingSignalsLoadWithBoundedWarnings) {
  const Database db = ParseDbcText(ManySignals(50'000, 8), "wide.dbc");
  ASSERT_EQ(db.messages.at(0).signals.size(), 50'000u);
  ASSERT_EQ(db.warnings.size(), 101u);
  EXPECT_NE(db.warnings[0].text.find("signals S0 and S64 of message WIDE overlap"), std::string::npos)
      << db.warnings[0].text;
  EXPECT_NE(db.warnings.back().text.find("49836 more signals overlap"), std::string::npos) << db.warnings.back().text;
}

// Catches: a multiplexed signal reported against a page it can never share a frame with, or
// missed against a plain signal and against its own page.
TEST(DbcLimits, OverlapRespectsMultiplexPages) {
  const Database db = ParseDbcText(R"(BO_ 1 M: 8 ECU
 SG_ Mux M : 0|8@1+ (1,0) [0|0] "" ECU
 SG_ A m1 : 8|8@1+ (1,0) [0|0] "" ECU
 SG_ B m2 : 8|8@1+ (1,0) [0|0] "" ECU
 SG_ C m1 : 12|8@1+ (1,0) [0|0] "" ECU
 SG_ Plain : 30|4@1+ (1,0) [0|0] "" ECU
 SG_ D m3 : 28|4@1+ (1,0) [0|0] "" ECU
)",
                                   "m.dbc");
  ASSERT_EQ(db.warnings.size(), 2u);
  EXPECT_NE(db.warnings[0].text.find("signals A and C of message M overlap"), std::string::npos) << db.warnings[0].text;
  EXPECT_NE(db.warnings[1].text.find("signals Plain and D of message M overlap"), std::string::npos) << db.warnings[1].text;
}

// Catches: reference resolution (CM_/VAL_ per signal) scanning every signal per reference.
TEST(DbcLimits, ValueTablesOnManySignalsResolve) {
  std::string text = ManySignals(20'000, 1);
  for (int i = 0; i < 20'000; i += 2) text += "VAL_ 1 S" + std::to_string(i) + " 0 \"off\" 1 \"on\";\n";
  const Database db = ParseDbcText(text, "t.dbc");
  EXPECT_EQ(db.messages.at(0).signals.at(19'998).value_table.at(1), "on");
  EXPECT_TRUE(db.messages.at(0).signals.at(19'999).value_table.empty());
}

}  // namespace
}  // namespace ndsid::dbc
