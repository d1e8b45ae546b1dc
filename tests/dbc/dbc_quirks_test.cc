// The real-world quirks a parser must survive (docs/dbc.md, "Quirk policy"): each loads with a
// Warning at the right line and column, and the rest of the file is still read.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "ndsid/dbc/dbc_parser.h"

namespace ndsid::dbc {
namespace {

Database Parse(const std::string& text) { return ParseDbcText(text, "quirk.dbc"); }

// The first warning containing `text`, or nullptr.
const Warning* FindWarning(const Database& db, const std::string& text) {
  for (const auto& w : db.warnings) {
    if (w.text.find(text) != std::string::npos) return &w;
  }
  return nullptr;
}

constexpr const char* kTwoMessages = R"(BO_ 304 GAS: 8 X
 SG_ PEDAL : 7|8@0+ (1,0) [0|255] "" X
BO_ 145 FCEV: 8 X
 SG_ ACCEL : 0|8@1+ (1,0) [0|255] "" X
)";

TEST(DbcQuirks, SignalCommentWithoutSignalNameIsIgnoredWithWarning) {
  // honda_civic_touring_2016_can_generated.dbc line 211
  const Database db = Parse(std::string(kTwoMessages) + "CM_ SG_ 304 \"Seems to be platform-agnostic\";\nCM_ SG_ 304 PEDAL \"kept\";\n");
  const Warning* w = FindWarning(db, "signal comment without a signal name");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->file, "quirk.dbc");
  EXPECT_EQ(w->line, 5);
  EXPECT_EQ(w->column, 13);
  EXPECT_EQ(db.messages[0].comment, "");
  EXPECT_EQ(db.messages[0].signals[0].comment, "kept") << "the statement after the quirk is still read";
}

TEST(DbcQuirks, MessageCommentWithoutBoKeywordIsTakenAsMessageComment) {
  // hyundai_can.dbc line 1656
  const Database db = Parse(std::string(kTwoMessages) + "CM_ 145 \"Contains signal with accelerator pedal press.\";\n");
  const Warning* w = FindWarning(db, "message comment without 'BO_'");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->line, 5);
  EXPECT_EQ(w->column, 5);
  EXPECT_EQ(db.FindMessage(145, false)->comment, "Contains signal with accelerator pedal press.");
}

TEST(DbcQuirks, ValueTableForMissingSignalIsIgnoredWithWarning) {
  // gm_global_a_powertrain.dbc: VAL_ 715 GasRegenCmdActiveInv
  const Database db = Parse(std::string(kTwoMessages) + "VAL_ 304 NO_SUCH_SIGNAL 1 \"Inactive\" 0 \"Active\" ;\nVAL_ 999 X 1 \"a\" ;\n");
  const Warning* w = FindWarning(db, "VAL_ value table for signal NO_SUCH_SIGNAL, which message GAS does not have");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->line, 5);
  EXPECT_EQ(w->column, 1);
  ASSERT_NE(FindWarning(db, "VAL_ value table for unknown message 999"), nullptr);
  EXPECT_TRUE(db.messages[0].signals[0].value_table.empty());
}

TEST(DbcQuirks, ValueTableWithoutSemicolonEndsAtNextStatement) {
  // toyota_new_mc_pt_generated.fb6ad760-2024-11.dbc line 569
  const Database db = Parse(std::string(kTwoMessages) +
                            "VAL_ 304 PEDAL 0 \"clutch pressed any amount\" 1 \"clutch released\"\n"
                            "VAL_ 145 ACCEL 2 \"disabled\" 11 \"hold\";\n");
  const Warning* w = FindWarning(db, "VAL_ statement without terminating ';'");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->line, 5);
  EXPECT_EQ(w->column, 1);
  EXPECT_EQ(db.messages[0].signals[0].value_table.size(), 2u) << "the unterminated table is kept";
  EXPECT_EQ(db.messages[1].signals[0].value_table.at(11), "hold") << "the next statement is read";
}

TEST(DbcQuirks, ValueTableWithoutSemicolonAtEndOfFileIsKept) {
  // gm_global_a_powertrain.dbc's last line (cantools drops this table silently)
  const Database db = Parse(std::string(kTwoMessages) + "VAL_ 304 PEDAL 1 \"Active\" 0 \"Inactive\"\n");
  ASSERT_NE(FindWarning(db, "VAL_ statement without terminating ';'"), nullptr);
  EXPECT_EQ(db.messages[0].signals[0].value_table.at(1), "Active");
}

TEST(DbcQuirks, OverlappingSignalsLoadWithWarning) {
  // toyota_new_mc_pt_generated.dbc PCS_HUD; vw_mqb.dbc PLA_01
  const Database db = Parse(R"(BO_ 1 PCS_HUD: 8 X
 SG_ A : 7|4@0+ (1,0) [0|15] "" X
 SG_ B : 5|4@0+ (1,0) [0|15] "" X
 SG_ C : 8|8@1+ (1,0) [0|15] "" X
)");
  ASSERT_EQ(db.warnings.size(), 1u);
  EXPECT_EQ(db.warnings[0].line, 3);
  EXPECT_NE(db.warnings[0].text.find("signals A and B of message PCS_HUD overlap"), std::string::npos);
  EXPECT_EQ(db.messages[0].signals.size(), 3u);
}

TEST(DbcQuirks, MultiplexedSignalOverlappingPlainSignalWarns) {
  const Database db = Parse(R"(BO_ 1 M: 8 X
 SG_ Page M : 0|4@1+ (1,0) [0|15] "" X
 SG_ Plain : 8|8@1+ (1,0) [0|15] "" X
 SG_ OnPage1 m1 : 12|8@1+ (1,0) [0|15] "" X
)");
  ASSERT_NE(FindWarning(db, "signals Plain and OnPage1 of message M overlap"), nullptr);
}

TEST(DbcQuirks, SignalBeyondMessageLengthLoadsWithWarning) {
  const Database db = Parse("BO_ 1 SHORT: 2 X\n SG_ S : 16|8@1+ (1,0) [0|0] \"\" X\n");
  const Warning* w = FindWarning(db, "signal S needs 3 bytes but message SHORT is 2 bytes long");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->line, 2);
}

TEST(DbcQuirks, DuplicateMessageIdKeepsTheFirstWithWarning) {
  const Database db = Parse("BO_ 5 FIRST: 8 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\nBO_ 5 SECOND: 8 X\n SG_ T : 0|8@1+ (1,0) [0|0] \"\" X\n");
  ASSERT_EQ(db.messages.size(), 1u);
  EXPECT_EQ(db.messages[0].name, "FIRST");
  const Warning* w = FindWarning(db, "duplicate message id 5 (SECOND)");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->line, 3);
}

TEST(DbcQuirks, SeveralMultiplexorsDisableMultiplexingLikeCantools) {
  const Database db = Parse(R"(BO_ 1 M: 8 X
 SG_ P1 M : 0|4@1+ (1,0) [0|15] "" X
 SG_ P2 M : 4|4@1+ (1,0) [0|15] "" X
 SG_ S m1 : 8|8@1+ (1,0) [0|15] "" X
)");
  ASSERT_NE(FindWarning(db, "has 2 multiplexor signals"), nullptr);
  for (const auto& s : db.messages[0].signals) EXPECT_EQ(s.mux_role, MuxRole::kNone) << s.name;
}

TEST(DbcQuirks, MultiplexedSignalWithoutMultiplexorBecomesPlain) {
  const Database db = Parse("BO_ 1 M: 8 X\n SG_ S m3 : 8|8@1+ (1,0) [0|15] \"\" X\n");
  ASSERT_NE(FindWarning(db, "no multiplexor"), nullptr);
  EXPECT_EQ(db.messages[0].signals[0].mux_role, MuxRole::kNone);
}

TEST(DbcQuirks, ExtendedMultiplexingIsReadAsSimpleMultiplexingWithWarning) {
  const Database db = Parse(R"(BO_ 1 M: 8 X
 SG_ P M : 0|4@1+ (1,0) [0|15] "" X
 SG_ Q m2M : 4|4@1+ (1,0) [0|15] "" X
SG_MUL_VAL_ 1 Q P 2-2;
)");
  ASSERT_NE(FindWarning(db, "extended multiplexing (m2M)"), nullptr);
  ASSERT_NE(FindWarning(db, "SG_MUL_VAL_"), nullptr);
  EXPECT_EQ(db.messages[0].signals[1].mux_role, MuxRole::kMultiplexed);
  EXPECT_EQ(db.messages[0].signals[1].mux_value, 2u);
}

TEST(DbcQuirks, UnknownSectionIsSkippedWithWarning) {
  const Database db = Parse(std::string(kTwoMessages) + "FOO_ 1 2 \"three\";\nCM_ BO_ 304 \"still read\";\n");
  const Warning* w = FindWarning(db, "unknown section 'FOO_'");
  ASSERT_NE(w, nullptr);
  EXPECT_EQ(w->line, 5);
  EXPECT_EQ(db.messages[0].comment, "still read");
}

// The files themselves (when the real-data folder is present): every one loads, and the four
// that cantools refuses give the warning that explains why.
TEST(DbcQuirks, RealOpendbcFilesLoadWithTheirDocumentedWarnings) {
  const std::string dir = NDSID_REALDATA_DIR "/opendbc-dbc";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "skipped: " << dir << " not found";
  struct Expected {
    const char* file;
    const char* warning;  // empty: only "loads"
    int line;
  };
  const Expected expected[] = {
      {"toyota_new_mc_pt_generated.fb6ad760-2024-11.dbc", "VAL_ statement without terminating ';'", 569},
      {"honda_civic_touring_2016_can_generated.dbc", "signal comment without a signal name", 211},
      {"hyundai_can.dbc", "message comment without 'BO_'", 1656},
      {"gm_global_a_powertrain.dbc", "VAL_ value table for signal GasRegenCmdActiveInv", 345},
      {"toyota_new_mc_pt_generated.dbc", "of message PCS_HUD overlap", 0},
      {"vw_mqb.dbc", "of message PLA_01 overlap", 0},
      {"ford_lincoln_base_pt.dbc", "", 0},
      {"tesla_model3_party.dbc", "", 0},
  };
  for (const auto& e : expected) {
    SCOPED_TRACE(e.file);
    const Database db = ParseDbcFile(dir + "/" + e.file);
    EXPECT_FALSE(db.messages.empty());
    if (*e.warning == '\0') {
      EXPECT_TRUE(db.warnings.empty());
      continue;
    }
    const Warning* w = FindWarning(db, e.warning);
    ASSERT_NE(w, nullptr);
    if (e.line > 0) {
      EXPECT_EQ(w->line, e.line);
    }
  }
}

}  // namespace
}  // namespace ndsid::dbc
