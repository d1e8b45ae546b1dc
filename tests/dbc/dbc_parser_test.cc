// Parser: each DBC construct, the cycle-time rule, and syntax errors with their file:line:column.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "ndsid/dbc/dbc_parser.h"

namespace ndsid::dbc {
namespace {

Database Parse(const std::string& text) { return ParseDbcText(text, "test.dbc"); }

// Runs the parser on text expected to fail; returns the error.
DbcError ParseError(const std::string& text) {
  try {
    Parse(text);
  } catch (const DbcError& e) {
    return e;
  }
  ADD_FAILURE() << "no DbcError for:\n" << text;
  return DbcError("", 0, 0, "");
}

constexpr const char* kHeader = R"(VERSION "1.2"

NS_ :
	NS_DESC_
	CM_
	BA_DEF_
	VAL_
	SIG_VALTYPE_

BS_:

BU_: ECU1 ECU2 LOGGER
)";

TEST(DbcParser, ReadsVersionNodesAndMessageHeader) {
  const Database db = Parse(std::string(kHeader) + "BO_ 291 ENGINE: 8 ECU1\n SG_ Rpm : 0|16@1+ (0.25,0) [0|16383.75] \"rpm\" LOGGER\n");
  EXPECT_EQ(db.version, "1.2");
  EXPECT_EQ(db.nodes, (std::vector<std::string>{"ECU1", "ECU2", "LOGGER"}));
  ASSERT_EQ(db.messages.size(), 1u);
  const Message& m = db.messages[0];
  EXPECT_EQ(m.id, 291u);
  EXPECT_FALSE(m.extended);
  EXPECT_EQ(m.name, "ENGINE");
  EXPECT_EQ(m.length, 8u);
  EXPECT_EQ(m.sender, "ECU1");
  EXPECT_EQ(m.line, 13);
  EXPECT_TRUE(db.warnings.empty());
}

TEST(DbcParser, ReadsEverySignalField) {
  const Database db = Parse(R"(BO_ 100 M: 8 ECU1
 SG_ Motorola : 7|12@0- (-0.1,40.5) [-204.8|204.7] "deg" ECU2,LOGGER
 SG_ Intel : 12|4@1+ (1E-2,-1.5e+1) [0|15] "m/s^2" ECU2
)");
  const Message& m = db.messages.at(0);
  ASSERT_EQ(m.signals.size(), 2u);
  const Signal& a = m.signals[0];
  EXPECT_EQ(a.name, "Motorola");
  EXPECT_EQ(a.start_bit, 7u);
  EXPECT_EQ(a.length, 12u);
  EXPECT_EQ(a.byte_order, ByteOrder::kBigEndian);
  EXPECT_EQ(a.value_type, ValueType::kSigned);
  EXPECT_DOUBLE_EQ(a.factor, -0.1);
  EXPECT_DOUBLE_EQ(a.offset, 40.5);
  EXPECT_DOUBLE_EQ(a.minimum, -204.8);
  EXPECT_DOUBLE_EQ(a.maximum, 204.7);
  EXPECT_EQ(a.unit, "deg");
  EXPECT_EQ(a.receivers, (std::vector<std::string>{"ECU2", "LOGGER"}));
  EXPECT_EQ(a.line, 2);
  const Signal& b = m.signals[1];
  EXPECT_EQ(b.byte_order, ByteOrder::kLittleEndian);
  EXPECT_EQ(b.value_type, ValueType::kUnsigned);
  EXPECT_DOUBLE_EQ(b.factor, 0.01);
  EXPECT_DOUBLE_EQ(b.offset, -15.0);
  EXPECT_EQ(b.unit, "m/s^2");
}

TEST(DbcParser, MasksBit31OfExtendedIds) {
  const Database db = Parse("BO_ 2566844672 VEHICLE_SPEED: 8 PCM\n SG_ S : 8|16@1+ (1,0) [0|0] \"\" X\n");
  ASSERT_EQ(db.messages.size(), 1u);
  EXPECT_TRUE(db.messages[0].extended);
  EXPECT_EQ(db.messages[0].id, 0x18FEF100u);
  EXPECT_NE(db.FindMessage(0x18FEF100u, true), nullptr);
  EXPECT_EQ(db.FindMessage(0x18FEF100u, false), nullptr);
}

TEST(DbcParser, ReadsMultiplexorAndMultiplexedSignals) {
  const Database db = Parse(R"(BO_ 992 STATUS: 8 BCM
 SG_ Page M : 0|4@1+ (1,0) [0|15] "" X
 SG_ Gear m0 : 8|4@1+ (1,0) [0|15] "" X
 SG_ Odometer m12 : 8|32@1+ (0.1,0) [0|0] "km" X
 SG_ Plain : 60|4@1+ (1,0) [0|15] "" X
)");
  const Message& m = db.messages.at(0);
  EXPECT_EQ(m.signals[0].mux_role, MuxRole::kMultiplexor);
  EXPECT_EQ(m.signals[1].mux_role, MuxRole::kMultiplexed);
  EXPECT_EQ(m.signals[1].mux_value, 0u);
  EXPECT_EQ(m.signals[2].mux_value, 12u);
  EXPECT_EQ(m.signals[3].mux_role, MuxRole::kNone);
  EXPECT_EQ(m.Multiplexor(), &m.signals[0]);
  EXPECT_TRUE(db.warnings.empty()) << "pages sharing bits are not overlaps";
}

TEST(DbcParser, AppliesCommentsValueTablesAndFloatTypes) {
  const Database db = Parse(R"(BO_ 1296 BATTERY: 16 PCM
 SG_ Voltage : 0|32@1- (1,0) [0|20] "V" X
 SG_ Energy : 64|64@1- (1,0) [0|0] "J" X
 SG_ State : 32|2@1+ (1,0) [0|3] "" X
CM_ "global one";
CM_ "global two";
CM_ BU_ PCM "the powertrain computer";
CM_ BO_ 1296 "Battery
spanning two lines";
CM_ SG_ 1296 State "charge state";
VAL_ 1296 State 0 "off" 1 "charging" -1 "error" ;
SIG_VALTYPE_ 1296 Voltage : 1;
SIG_VALTYPE_ 1296 Energy : 2;
)");
  EXPECT_EQ(db.comment, "global one\nglobal two");
  const Message& m = db.messages.at(0);
  EXPECT_EQ(m.comment, "Battery\nspanning two lines");
  EXPECT_EQ(m.signals[0].value_type, ValueType::kFloat32);
  EXPECT_EQ(m.signals[1].value_type, ValueType::kFloat64);
  EXPECT_EQ(m.signals[2].comment, "charge state");
  EXPECT_EQ(m.signals[2].value_table, (std::map<int64_t, std::string>{{-1, "error"}, {0, "off"}, {1, "charging"}}));
}

TEST(DbcParser, UnescapesQuotesInStrings) {
  const Database db = Parse("BO_ 1 A: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nCM_ SG_ 1 S \"say \\\"hi\\\" \\\\ there\";\n");
  EXPECT_EQ(db.messages.at(0).signals.at(0).comment, "say \"hi\" \\ there");
}

TEST(DbcParser, ResolvesSectionsInterleavedBetweenMessages) {
  // As in opendbc's generated files: VAL_/CM_ of a message may come before or after other BO_.
  const Database db = Parse(R"(CM_ "file comment before VERSION";
VERSION ""
VAL_ 2 B 1 "one" ;
BO_ 1 FIRST: 8 X
 SG_ A : 0|8@1+ (1,0) [0|0] "" X
CM_ SG_ 1 A "comment of A";
CM_ SG_ 2 B "comment of B, whose message comes later";
BO_ 2 SECOND: 8 X
 SG_ B : 0|8@1+ (1,0) [0|0] "" X
VAL_ 1 A 0 "zero" ;
)");
  ASSERT_EQ(db.messages.size(), 2u);
  EXPECT_EQ(db.messages[0].signals[0].comment, "comment of A");
  EXPECT_EQ(db.messages[0].signals[0].value_table.at(0), "zero");
  EXPECT_EQ(db.messages[1].signals[0].comment, "comment of B, whose message comes later");
  EXPECT_EQ(db.messages[1].signals[0].value_table.at(1), "one");
  EXPECT_TRUE(db.warnings.empty());
}

TEST(DbcParser, CycleTimeFollowsCantoolsRule) {
  // Explicit value wins; without one the BA_DEF_DEF_ default applies; 0 means none.
  const std::string messages = "BO_ 1 A: 8 X\nBO_ 2 B: 8 X\nBO_ 3 C: 8 X\n";
  const Database with_default = Parse(messages + R"(BA_DEF_ BO_ "GenMsgCycleTime" INT 0 10000;
BA_DEF_DEF_ "GenMsgCycleTime" 100;
BA_ "GenMsgCycleTime" BO_ 1 10;
BA_ "GenMsgCycleTime" BO_ 3 0;
)");
  EXPECT_EQ(with_default.messages[0].cycle_time_ms, 10.0);
  EXPECT_EQ(with_default.messages[1].cycle_time_ms, 100.0);
  EXPECT_FALSE(with_default.messages[2].cycle_time_ms.has_value());

  const Database zero_default = Parse(messages + R"(BA_DEF_ BO_ "GenMsgCycleTime" INT 0 10000;
BA_DEF_DEF_ "GenMsgCycleTime" 0;
BA_ "GenMsgCycleTime" BO_ 2 20;
)");
  EXPECT_FALSE(zero_default.messages[0].cycle_time_ms.has_value());
  EXPECT_EQ(zero_default.messages[1].cycle_time_ms, 20.0);

  const Database undefined = Parse(messages + "BA_ \"GenMsgCycleTime\" BO_ 1 10;\n");
  EXPECT_FALSE(undefined.messages[0].cycle_time_ms.has_value()) << "cantools ignores BA_ without BA_DEF_";
}

TEST(DbcParser, SkipsSectionsItDoesNotNeedWithoutWarnings) {
  const Database db = Parse(std::string(kHeader) + R"(VAL_TABLE_ Onoff 1 "on" 0 "off" ;
BO_ 2147484672 EXT: 8 ECU1
 SG_ S : 0|8@1+ (1,0) [0|255] "" ECU2
BO_TX_BU_ 2147484672 : ECU1,ECU2;
EV_ Env1: 0 [0|1] "" 0 1 DUMMY_NODE_VECTOR0 Vector__XXX;
ENVVAR_DATA_ Env1: 4;
VAL_ Env1 0 "a" 1 "b" ;
SIG_GROUP_ 2147484672 Grp 1 : S;
BA_DEF_ SG_ "GenSigStartValue" INT 0 100000;
BA_DEF_ "BusType" STRING ;
BA_DEF_ BO_ "VFrameFormat" ENUM "StandardCAN","ExtendedCAN";
BA_DEF_REL_ BU_SG_REL_ "X" INT 0 1;
BA_DEF_DEF_ "BusType" "CAN";
BA_DEF_DEF_ "VFrameFormat" "StandardCAN";
BA_ "BusType" "CAN";
BA_ "VFrameFormat" BO_ 2147484672 1;
BA_ "GenSigStartValue" SG_ 2147484672 S 5;
BA_ "X" BU_ ECU1 1;
BA_REL_ "X" BU_SG_REL_ ECU1 SG_ 2147484672 S 1;
)");
  EXPECT_TRUE(db.warnings.empty()) << db.warnings.front().text;
  ASSERT_EQ(db.messages.size(), 1u);
  EXPECT_EQ(db.messages[0].id, 1024u);
  EXPECT_EQ(db.messages[0].signals.size(), 1u);
}

TEST(DbcParser, DropsDuplicateAndPlaceholderReceivers) {
  const Database db = Parse("BO_ 1 A: 8 Vector__XXX\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" ECU1,ECU2 ECU1,Vector__XXX\n");
  EXPECT_EQ(db.messages[0].signals[0].receivers, (std::vector<std::string>{"ECU1", "ECU2"}));
}

TEST(DbcParser, AcceptsCrlfLineEndingsAndByteOrderMark) {
  const Database db = Parse("\xEF\xBB\xBFVERSION \"x\"\r\n\r\nBO_ 1 A: 8 X\r\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\r\n");
  ASSERT_EQ(db.messages.size(), 1u);
  EXPECT_EQ(db.messages[0].signals.size(), 1u);
}

TEST(DbcParser, ErrorMessageIsFileLineColumn) {
  const DbcError e = ParseError("BO_ 1 A: 8 X\n SG_ S : 0|8@2+ (1,0) [0|0] \"\" X\n");
  EXPECT_EQ(e.file(), "test.dbc");
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 14);
  EXPECT_EQ(std::string(e.what()).rfind("test.dbc:2:14: byte order must be 0 (Motorola) or 1 (Intel)", 0), 0u) << e.what();
}

TEST(DbcParser, RejectsMissingSignAfterByteOrder) {
  const DbcError e = ParseError("BO_ 1 A: 8 X\n SG_ S : 0|8@1 (1,0) [0|0] \"\" X\n");
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 16);
}

TEST(DbcParser, RejectsSignalLengthZeroOrAbove64) {
  EXPECT_EQ(ParseError("BO_ 1 A: 8 X\n SG_ S : 0|65@1+ (1,0) [0|0] \"\" X\n").column(), 12);
  EXPECT_EQ(ParseError("BO_ 1 A: 8 X\n SG_ S : 0|0@1+ (1,0) [0|0] \"\" X\n").line(), 2);
}

TEST(DbcParser, RejectsSignalBeyondA64BytePayload) {
  EXPECT_EQ(ParseError("BO_ 1 A: 64 X\n SG_ S : 500|16@1+ (1,0) [0|0] \"\" X\n").column(), 10);
  EXPECT_EQ(ParseError("BO_ 1 A: 64 X\n SG_ S : 512|1@1+ (1,0) [0|0] \"\" X\n").column(), 10);
  // Motorola runs towards higher bytes: MSB at byte 63 bit 0 leaves no room for a second bit.
  EXPECT_EQ(ParseError("BO_ 1 A: 64 X\n SG_ S : 504|2@0+ (1,0) [0|0] \"\" X\n").line(), 2);
}

TEST(DbcParser, RejectsMessageLongerThan64Bytes) {
  const DbcError e = ParseError("BO_ 1 A: 65 X\n");
  EXPECT_EQ(e.line(), 1);
  EXPECT_EQ(e.column(), 10);
}

TEST(DbcParser, RejectsSignalOutsideAMessage) {
  const DbcError e = ParseError("BO_ 1 A: 8 X\nCM_ \"x\";\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n");
  EXPECT_EQ(e.line(), 3);
  EXPECT_EQ(e.column(), 2);
  EXPECT_NE(std::string(e.what()).find("SG_ outside a BO_"), std::string::npos);
}

TEST(DbcParser, RejectsUnterminatedStringAtEndOfFile) {
  const DbcError e = ParseError("BO_ 1 A: 8 X\nCM_ BO_ 1 \"never closed;\n\n");
  EXPECT_EQ(e.line(), 2);
  EXPECT_EQ(e.column(), 11);
  EXPECT_NE(std::string(e.what()).find("unterminated string"), std::string::npos);
}

TEST(DbcParser, RejectsStrayCharacter) {
  const DbcError e = ParseError("BO_ 1 A: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n$\n");
  EXPECT_EQ(e.line(), 3);
  EXPECT_EQ(e.column(), 1);
}

TEST(DbcParser, RejectsBadMultiplexerIndicator) {
  EXPECT_EQ(ParseError("BO_ 1 A: 8 X\n SG_ S x3 : 0|8@1+ (1,0) [0|0] \"\" X\n").column(), 8);
}

TEST(DbcParser, RejectsFloatValueTypeOnWrongLength) {
  const DbcError e = ParseError("BO_ 1 A: 8 X\n SG_ S : 0|16@1+ (1,0) [0|0] \"\" X\nSIG_VALTYPE_ 1 S : 1;\n");
  EXPECT_EQ(e.line(), 3);
  EXPECT_EQ(e.column(), 20);
}

TEST(DbcParser, RejectsMissingSemicolonInsideALine) {
  // Tolerated only when the next statement starts on a new line (see the quirk tests).
  const DbcError e = ParseError("BO_ 1 A: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nCM_ BO_ 1 \"c\" CM_ \"d\";\n");
  EXPECT_EQ(e.line(), 3);
  EXPECT_EQ(e.column(), 15);
}

TEST(DbcParser, MissingFileThrowsDbcErrorNamingIt) {
  try {
    ParseDbcFile("/nonexistent/x.dbc");
    FAIL() << "no exception";
  } catch (const DbcError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/x.dbc"), std::string::npos);
  }
}

TEST(DbcParser, LoadsTheExampleVehicleDbcWithoutWarnings) {
  const Database db = ParseDbcFile(NDSID_SOURCE_DIR "/dbc/ndsid_example.dbc");
  EXPECT_TRUE(db.warnings.empty());
  EXPECT_EQ(db.messages.size(), 8u);
  const Message* speed = db.FindMessage("VEHICLE_SPEED");
  ASSERT_NE(speed, nullptr);
  EXPECT_TRUE(speed->extended);
  EXPECT_EQ(speed->id, 0x18FEF100u);
  EXPECT_EQ(speed->cycle_time_ms, 20.0);
  EXPECT_EQ(db.FindMessage("BATTERY")->FindSignal("BatteryVoltage")->value_type, ValueType::kFloat32);
  EXPECT_EQ(db.FindMessage("VEHICLE_STATUS")->Multiplexor()->name, "StatusPage");
}

TEST(DbcParser, ParsesTheLargestRealFileWellUnderASecond) {
  const std::string path = NDSID_REALDATA_DIR "/opendbc-dbc/ford_lincoln_base_pt.dbc";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "skipped: " << path << " not found";
  const auto t0 = std::chrono::steady_clock::now();
  const Database db = ParseDbcFile(path);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(db.messages.size(), 331u);
  EXPECT_LT(seconds, 0.5) << "807 kB took " << seconds << " s";
}

}  // namespace
}  // namespace ndsid::dbc
