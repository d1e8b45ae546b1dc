// Decoder: hand-computed and cantools-computed vectors, multiplexing, extended ids, short and
// CAN FD frames, and randomized payloads against the naive bit-walking reference decoder.
#include <gtest/gtest.h>

#include <atomic>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "naive_reference.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

// Counts heap allocations, to check that Decode() makes none. GCC 12 cannot tell that these
// replacements pair malloc with free and warns; the pairing is correct.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<long> g_allocations{0};
}
void* operator new(std::size_t size) {
  ++g_allocations;
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace ndsid::dbc {
namespace {

can::CanFrame Frame(uint32_t id, std::vector<uint8_t> bytes, uint8_t flags = 0) {
  can::CanFrame f;
  f.id = id;
  f.flags = flags;
  f.len = static_cast<uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

// Decodes `frame` and returns signal name -> value, with the verdict.
std::map<std::string, double> DecodeAll(const Decoder& d, const can::CanFrame& frame, DecodeVerdict* verdict = nullptr) {
  std::vector<DecodedValue> out(d.max_signals_per_message());
  size_t count = 0;
  const DecodeVerdict v = d.Decode(frame, out, count);
  if (verdict) *verdict = v;
  std::map<std::string, double> values;
  for (size_t i = 0; i < count; ++i) values[d.signals()[static_cast<size_t>(out[i].signal_index)].signal->name] = out[i].value;
  return values;
}

// The four lateral-dynamics messages of toyota_new_mc_pt_generated.dbc, verbatim.
constexpr const char* kToyota = R"(
BO_ 36 KINEMATICS: 8 XXX
 SG_ ACCEL_Y : 33|10@0+ (0.03589,-18.375) [0|65535] "m/s^2" XXX
 SG_ YAW_RATE : 1|10@0+ (0.244,-125) [0|65535] "deg/s" XXX
 SG_ ACCEL_X : 17|10@0+ (0.03589,-18.375) [0|65535] "m/s^2" XXX
BO_ 37 STEER_ANGLE_SENSOR: 8 XXX
 SG_ STEER_ANGLE : 3|12@0- (1.5,0) [-500|500] "deg" XXX
 SG_ STEER_FRACTION : 39|4@0- (0.1,0) [-0.7|0.7] "deg" XXX
 SG_ STEER_RATE : 35|12@0- (1,0) [-2000|2000] "deg/s" XXX
BO_ 170 WHEEL_SPEEDS: 8 XXX
 SG_ WHEEL_SPEED_FR : 6|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_FL : 22|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_RR : 38|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_RL : 54|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
BO_ 180 SPEED: 8 XXX
 SG_ SPEED : 47|16@0+ (0.01,0) [0|250] "km/h" XXX
)";

TEST(Decoder, MatchesCantoolsOnRealRav4Frames) {
  // Test vectors from realdata/comma2k19-rav4-2017-segment/README.md (physical values by cantools).
  const Database db = ParseDbcText(kToyota, "toyota.dbc");
  const Decoder d(db);
  auto steer = DecodeAll(d, Frame(0x25, {0x0F, 0xFD, 0x10, 0x00, 0xFF, 0xFD, 0x00, 0x45}));
  EXPECT_DOUBLE_EQ(steer["STEER_ANGLE"], -4.5);
  EXPECT_DOUBLE_EQ(steer["STEER_FRACTION"], -0.1);
  EXPECT_DOUBLE_EQ(steer["STEER_RATE"], -3);
  auto kin = DecodeAll(d, Frame(0x24, {0x01, 0xF7, 0x02, 0x07, 0x42, 0x13, 0x80, 0x02}));
  EXPECT_NEAR(kin["YAW_RATE"], -2.268, 1e-9);
  EXPECT_NEAR(kin["ACCEL_X"], 0.25191, 1e-9);
  EXPECT_NEAR(kin["ACCEL_Y"], 0.68259, 1e-9);
  EXPECT_NEAR(DecodeAll(d, Frame(0xB4, {0, 0, 0, 0, 0xB1, 0x1C, 0x89, 0x12}))["SPEED"], 73.05, 1e-9);
  auto wheels = DecodeAll(d, Frame(0xAA, {0x36, 0x43, 0x36, 0x78, 0x36, 0x45, 0x36, 0x55}));
  EXPECT_NEAR(wheels["WHEEL_SPEED_FR"], 71.24, 1e-9);
  EXPECT_NEAR(wheels["WHEEL_SPEED_FL"], 71.77, 1e-9);
  EXPECT_NEAR(wheels["WHEEL_SPEED_RR"], 71.26, 1e-9);
  EXPECT_NEAR(wheels["WHEEL_SPEED_RL"], 71.42, 1e-9);
}

TEST(Decoder, ExtractsIntelSignalsAcrossByteBoundaries) {
  const Database db = ParseDbcText(R"(BO_ 1 M: 8 X
 SG_ Mid : 4|12@1+ (1,0) [0|0] "" X
 SG_ Signed : 16|8@1- (1,0) [0|0] "" X
 SG_ Wide : 20|44@1+ (1,0) [0|0] "" X
)", "t.dbc");
  auto v = DecodeAll(Decoder(db), Frame(1, {0xAB, 0xCD, 0x80, 0x12, 0x34, 0x56, 0x78, 0x9A}));
  EXPECT_EQ(v["Mid"], 0xCDA);     // bits 4..15 of 0xCDAB
  EXPECT_EQ(v["Signed"], -128);   // 0x80
  EXPECT_EQ(v["Wide"], static_cast<double>(0x9A785634128ull));  // 0x9A7856341280CDAB >> 20
}

TEST(Decoder, ExtractsMotorolaSignalsInDbcNumbering) {
  const Database db = ParseDbcText(R"(BO_ 1 M: 8 X
 SG_ Word : 7|16@0+ (1,0) [0|0] "" X
 SG_ Nibbles : 19|8@0+ (1,0) [0|0] "" X
 SG_ Bit : 32|1@0- (1,0) [0|0] "" X
)", "t.dbc");
  // Word: bytes 0..1 = 0x1234. Nibbles: MSB at byte 2 bit 3, i.e. low nibble of byte 2 then high
  // nibble of byte 3: 0xC and 0xD -> 0xCD. Bit: byte 4 bit 0, signed 1-bit -> -1.
  auto v = DecodeAll(Decoder(db), Frame(1, {0x12, 0x34, 0xAC, 0xD0, 0x01, 0, 0, 0}));
  EXPECT_EQ(v["Word"], 0x1234);
  EXPECT_EQ(v["Nibbles"], 0xCD);
  EXPECT_EQ(v["Bit"], -1);
}

TEST(Decoder, SignExtendsAndHandles64BitSignals) {
  const Database db = ParseDbcText(R"(BO_ 1 M: 8 X
 SG_ S64 : 0|64@1- (1,0) [0|0] "" X
BO_ 2 N: 8 X
 SG_ U64 : 7|64@0+ (1,0) [0|0] "" X
)", "t.dbc");
  const Decoder d(db);
  EXPECT_EQ(DecodeAll(d, Frame(1, {0xFE, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}))["S64"], -2);
  EXPECT_EQ(DecodeAll(d, Frame(2, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}))["U64"], 18446744073709551615.0);
}

TEST(Decoder, DecodesIeeeFloatSignalsWithScaling) {
  const Database db = ParseDbcText(R"(BO_ 1 M: 12 X
 SG_ F32 : 0|32@1- (2,1) [0|0] "" X
 SG_ F64 : 32|64@1- (1,0) [0|0] "" X
SIG_VALTYPE_ 1 F32 : 1;
SIG_VALTYPE_ 1 F64 : 2;
)", "t.dbc");
  std::vector<uint8_t> bytes(12);
  const float f = 12.5f;
  const double g = -3.25e-300;
  std::memcpy(bytes.data(), &f, 4);  // little-endian host, as the DBC's @1
  std::memcpy(bytes.data() + 4, &g, 8);
  auto v = DecodeAll(Decoder(db), Frame(1, bytes, can::kFlagFd));
  EXPECT_EQ(v["F32"], 26.0);
  EXPECT_EQ(v["F64"], g);
  const float nan = std::nanf("");
  std::memcpy(bytes.data(), &nan, 4);
  EXPECT_TRUE(std::isnan(DecodeAll(Decoder(db), Frame(1, bytes, can::kFlagFd))["F32"]));
}

constexpr const char* kMux = R"(BO_ 992 STATUS: 8 BCM
 SG_ Page M : 0|4@1+ (1,0) [0|15] "" X
 SG_ Gear m0 : 8|4@1+ (1,0) [0|15] "" X
 SG_ Odometer m1 : 8|32@1+ (0.1,0) [0|0] "km" X
 SG_ Plain : 56|8@1+ (1,0) [0|0] "" X
)";

TEST(Decoder, EmitsOnlyTheMultiplexedPageSelected) {
  const Database db = ParseDbcText(kMux, "t.dbc");
  const Decoder d(db);
  auto page0 = DecodeAll(d, Frame(992, {0x00, 0x03, 0, 0, 0, 0, 0, 7}));
  EXPECT_EQ(page0, (std::map<std::string, double>{{"Page", 0}, {"Gear", 3}, {"Plain", 7}}));
  auto page1 = DecodeAll(d, Frame(992, {0x01, 0x0A, 0, 0, 0, 0, 0, 7}));
  EXPECT_EQ(page1.count("Gear"), 0u);
  EXPECT_DOUBLE_EQ(page1["Odometer"], 1.0);
  auto undefined_page = DecodeAll(d, Frame(992, {0x05, 0x0A, 0, 0, 0, 0, 0, 7}));
  EXPECT_EQ(undefined_page, (std::map<std::string, double>{{"Page", 5}, {"Plain", 7}}));
}

TEST(Decoder, ChecksTheMultiplexorEvenWhenItIsNotSelected) {
  const Database db = ParseDbcText(kMux, "t.dbc");
  const SignalSelector only_gear[] = {{"STATUS", "Gear"}};
  const Decoder d(db, only_gear);
  EXPECT_EQ(DecodeAll(d, Frame(992, {0x00, 0x03, 0, 0, 0, 0, 0, 0})).size(), 1u);
  EXPECT_TRUE(DecodeAll(d, Frame(992, {0x01, 0x03, 0, 0, 0, 0, 0, 0})).empty());
}

TEST(Decoder, KeepsStandardAndExtendedIdsApart) {
  const Database db = ParseDbcText("BO_ 2147483905 EXT: 1 X\n SG_ E : 0|8@1+ (1,0) [0|0] \"\" X\nBO_ 257 STD: 1 X\n SG_ S : 0|8@1+ (1,0) [0|0] \"\" X\n", "t.dbc");
  const Decoder d(db);
  EXPECT_EQ(DecodeAll(d, Frame(257, {9}, can::kFlagExtended)).count("E"), 1u);
  EXPECT_EQ(DecodeAll(d, Frame(257, {9})).count("S"), 1u);
  DecodeVerdict verdict;
  DecodeAll(d, Frame(258, {9}, can::kFlagExtended), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kUnknownId);
}

TEST(Decoder, ShortFrameDecodesTheSignalsThatFitAndSaysTooShort) {
  const Database db = ParseDbcText(kToyota, "toyota.dbc");
  DecodeVerdict verdict;
  auto v = DecodeAll(Decoder(db), Frame(0x25, {0x0F, 0xFD, 0x10, 0x00}), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kTooShort);
  EXPECT_EQ(v, (std::map<std::string, double>{{"STEER_ANGLE", -4.5}}));
  DecodeAll(Decoder(db), Frame(0x25, {}), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kTooShort);
  // A frame longer than the DBC length decodes normally.
  DecodeAll(Decoder(db), Frame(0x25, {0x0F, 0xFD, 0x10, 0x00, 0xFF, 0xFD, 0x00, 0x45, 0, 0, 0, 0}, can::kFlagFd), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kDecoded);
}

TEST(Decoder, ShortFrameWithoutTheMultiplexorSaysTooShort) {
  const Database db = ParseDbcText("BO_ 1 M: 8 X\n SG_ P M : 32|4@1+ (1,0) [0|15] \"\" X\n SG_ Q m0 : 0|4@1+ (1,0) [0|15] \"\" X\n", "t.dbc");
  DecodeVerdict verdict;
  EXPECT_TRUE(DecodeAll(Decoder(db), Frame(1, {0, 0}), &verdict).empty());
  EXPECT_EQ(verdict, DecodeVerdict::kTooShort);
}

TEST(Decoder, DecodesCanFdSignalsBeyondEightBytes) {
  const Database db = ParseDbcText("BO_ 1 FD: 64 X\n SG_ Last : 496|16@1+ (1,0) [0|0] \"\" X\n SG_ LastM : 511|8@0+ (1,0) [0|0] \"\" X\n", "t.dbc");
  std::vector<uint8_t> bytes(64);
  bytes[62] = 0x34;
  bytes[63] = 0x12;
  auto v = DecodeAll(Decoder(db), Frame(1, bytes, can::kFlagFd));
  EXPECT_EQ(v["Last"], 0x1234);
  EXPECT_EQ(v["LastM"], 0x12);
}

TEST(Decoder, RemoteAndErrorFramesAreNotData) {
  const Database db = ParseDbcText(kToyota, "toyota.dbc");
  DecodeVerdict verdict;
  DecodeAll(Decoder(db), Frame(0x25, {}, can::kFlagRemote), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kNotData);
  DecodeAll(Decoder(db), Frame(0x25, std::vector<uint8_t>(8), can::kFlagError), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kNotData);
}

TEST(Decoder, SelectionLimitsSignalsAndUnknownNamesThrow) {
  const Database db = ParseDbcText(kToyota, "toyota.dbc");
  const SignalSelector sel[] = {{"SPEED", "SPEED"}, {"KINEMATICS", "YAW_RATE"}, {"SPEED", "SPEED"}};
  const Decoder d(db, sel);
  EXPECT_EQ(d.signals().size(), 2u);
  EXPECT_EQ(d.max_signals_per_message(), 1u);
  EXPECT_EQ(d.SignalIndex("KINEMATICS", "YAW_RATE"), 1);
  EXPECT_EQ(d.SignalIndex("KINEMATICS", "ACCEL_X"), -1);
  DecodeVerdict verdict;
  DecodeAll(d, Frame(0x25, std::vector<uint8_t>(8)), &verdict);
  EXPECT_EQ(verdict, DecodeVerdict::kUnknownId) << "no selected signal in STEER_ANGLE_SENSOR";
  const SignalSelector bad_message[] = {{"NOPE", "SPEED"}};
  EXPECT_THROW(Decoder(db, bad_message), ConfigError);
  const SignalSelector bad_signal[] = {{"SPEED", "NOPE"}};
  EXPECT_THROW(Decoder(db, bad_signal), ConfigError);
}

TEST(Decoder, DecodeMakesNoHeapAllocation) {
  const Database db = ParseDbcText(kMux, "t.dbc");
  const Decoder d(db);
  std::vector<DecodedValue> out(d.max_signals_per_message());
  const can::CanFrame frame = Frame(992, {0x01, 0x0A, 0, 0, 0, 0, 0, 7});
  size_t count = 0;
  const long before = g_allocations.load();
  for (int i = 0; i < 100; ++i) d.Decode(frame, out, count);
  EXPECT_EQ(g_allocations.load(), before);
  EXPECT_EQ(count, 3u);
}

// Every signal of every file, random payloads of the declared length (and some shorter),
// against the naive reference decoder. Seeded, so a failure reproduces.
void CheckAgainstNaiveReference(const Database& db, int payloads_per_message) {
  const Decoder d(db);
  std::mt19937_64 rng(20240611);
  std::vector<DecodedValue> out(d.max_signals_per_message());
  int compared = 0;
  for (const auto& m : db.messages) {
    const Signal* mux = m.Multiplexor();
    for (int k = 0; k < payloads_per_message; ++k) {
      can::CanFrame f;
      f.id = m.id;
      f.flags = m.extended ? can::kFlagExtended : 0;
      f.len = static_cast<uint8_t>(k % 10 == 9 ? rng() % (m.length + 1) : m.length);
      for (auto& b : f.data) b = static_cast<uint8_t>(rng());
      size_t count = 0;
      d.Decode(f, out, count);
      std::map<const Signal*, double> got;
      for (size_t i = 0; i < count; ++i) got[d.signals()[static_cast<size_t>(out[i].signal_index)].signal] = out[i].value;
      const auto mux_raw = mux ? testing::NaiveRaw(*mux, f.payload()) : std::nullopt;
      for (const auto& s : m.signals) {
        auto expected = testing::NaivePhysical(s, f.payload());
        if (s.mux_role == MuxRole::kMultiplexed && (!mux_raw || *mux_raw != s.mux_value)) expected.reset();
        ASSERT_EQ(got.count(&s), expected ? 1u : 0u) << m.name << "." << s.name << " len " << int(f.len);
        if (!expected) continue;
        ++compared;
        if (std::isnan(*expected)) {
          EXPECT_TRUE(std::isnan(got[&s])) << m.name << "." << s.name;
        } else {
          ASSERT_EQ(got[&s], *expected) << m.name << "." << s.name;
        }
      }
    }
  }
  EXPECT_GT(compared, 0);
}

TEST(Decoder, MatchesNaiveReferenceOnRandomPayloadsOfExampleDbc) {
  CheckAgainstNaiveReference(ParseDbcFile(NDSID_SOURCE_DIR "/dbc/ndsid_example.dbc"), 500);
}

TEST(Decoder, MatchesNaiveReferenceOnRandomPayloadsOfRealDbcs) {
  const std::string dir = NDSID_REALDATA_DIR "/opendbc-dbc";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "skipped: " << dir << " not found";
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".dbc") continue;
    SCOPED_TRACE(entry.path().filename().string());
    CheckAgainstNaiveReference(ParseDbcFile(entry.path().string()), 50);
  }
}

}  // namespace
}  // namespace ndsid::dbc
