// ParseCandumpLine / FormatCandumpLine: every frame kind candump writes, the exact timestamp
// conversion, the malformed cases, and the round trip.
#include <gtest/gtest.h>

#include <random>

#include "ndsid/can/candump_reader.h"

namespace ndsid::can {
namespace {

struct Parsed {
  std::string error;
  CanFrame frame;
  std::string bus;
};

Parsed Parse(std::string_view line) {
  Parsed p;
  std::string_view bus;
  p.error = ParseCandumpLine(line, p.frame, bus);
  p.bus = std::string(bus);
  return p;
}

std::vector<uint8_t> Payload(const CanFrame& f) { return {f.payload().begin(), f.payload().end()}; }

TEST(CandumpLine, ParsesStandardDataFrame) {
  const Parsed p = Parse("(1700000000.123456) can0 123#DEADBEEF");
  ASSERT_EQ(p.error, "");
  EXPECT_EQ(p.frame.timestamp_ns, 1700000000123456000);
  EXPECT_EQ(p.bus, "can0");
  EXPECT_EQ(p.frame.id, 0x123u);
  EXPECT_EQ(p.frame.flags, 0);
  EXPECT_EQ(Payload(p.frame), (std::vector<uint8_t>{0xDE, 0xAD, 0xBE, 0xEF}));
}

TEST(CandumpLine, ParsesLowercaseHexAndZeroLengthFrame) {
  Parsed p = Parse("(1.000001) vcan0 7ff#deadbeef");
  ASSERT_EQ(p.error, "");
  EXPECT_EQ(p.frame.id, 0x7FFu);
  EXPECT_EQ(p.frame.data[0], 0xDE);
  p = Parse("(1.000001) can0 000#");
  ASSERT_EQ(p.error, "");
  EXPECT_EQ(p.frame.len, 0);
}

TEST(CandumpLine, EightDigitIdIsExtendedEvenWhenSmall) {
  Parsed p = Parse("(5.5) can1 18FEF100#0102030405060708");
  ASSERT_EQ(p.error, "");
  EXPECT_EQ(p.frame.id, 0x18FEF100u);
  EXPECT_TRUE(p.frame.extended());
  EXPECT_EQ(p.frame.len, 8);
  p = Parse("(5.5) can1 00000123#01");
  ASSERT_EQ(p.error, "");
  EXPECT_EQ(p.frame.id, 0x123u);
  EXPECT_TRUE(p.frame.extended());
}

TEST(CandumpLine, TimestampFractionOfAnyLengthConvertsExactly) {
  // Parsed as integers: 0.000001 s is 1000 ns with no binary rounding.
  EXPECT_EQ(Parse("(46408.584930) can0 025#00").frame.timestamp_ns, 46408584930000);
  EXPECT_EQ(Parse("(1.5) can0 025#00").frame.timestamp_ns, 1500000000);
  EXPECT_EQ(Parse("(1.123456789) can0 025#00").frame.timestamp_ns, 1123456789);
  EXPECT_EQ(Parse("(9223372035.999999) can0 025#00").frame.timestamp_ns, 9223372035999999000);
  EXPECT_EQ(Parse("(1.0000000001) can0 025#00").error, "timestamp fraction longer than 9 digits");
  EXPECT_EQ(Parse("(99999999999.0) can0 025#00").error, "timestamp out of range");
}

TEST(CandumpLine, RemoteFramesKeepRequestedDlc) {
  Parsed p = Parse("(1.000000) can0 123#R");
  ASSERT_EQ(p.error, "");
  EXPECT_TRUE(p.frame.remote());
  EXPECT_EQ(p.frame.len, 0);
  p = Parse("(1.000000) can0 1ABCDEF0#R5");
  ASSERT_EQ(p.error, "");
  EXPECT_TRUE(p.frame.remote());
  EXPECT_TRUE(p.frame.extended());
  EXPECT_EQ(p.frame.len, 5);
  EXPECT_EQ(p.frame.data[0], 0) << "a remote frame carries no data";
  EXPECT_EQ(Parse("(1.000000) can0 123#R9").error, "bad remote frame DLC");
  EXPECT_EQ(Parse("(1.000000) can0 123#R12").error, "bad remote frame DLC");
}

TEST(CandumpLine, CanFdFramesCarryFlagsAndLongPayload) {
  std::string data;
  for (int i = 0; i < 64; ++i) data += "A5";
  Parsed p = Parse("(2.000000) can0 123##3" + data);
  ASSERT_EQ(p.error, "");
  EXPECT_TRUE(p.frame.fd());
  EXPECT_EQ(p.frame.flags & kFlagFdBrs, kFlagFdBrs);
  EXPECT_EQ(p.frame.flags & kFlagFdEsi, kFlagFdEsi);
  EXPECT_EQ(p.frame.len, 64);
  EXPECT_EQ(p.frame.data[63], 0xA5);
  p = Parse("(2.000000) can0 123##0");
  ASSERT_EQ(p.error, "");
  EXPECT_TRUE(p.frame.fd());
  EXPECT_EQ(p.frame.len, 0);
  EXPECT_EQ(Parse("(2.0) can0 123##4" + data.substr(0, 24)).error, "")
      << "FDF (4) in the flags nibble is what newer can-utils write";
  EXPECT_EQ(Parse("(2.0) can0 123##1" + data.substr(0, 20)).error,
            "CAN FD length not expressible by a DLC");
  EXPECT_EQ(Parse("(2.0) can0 123##8" + data.substr(0, 2)).error, "unknown CAN FD flags");
  EXPECT_EQ(Parse("(2.0) can0 123##" ).error, "CAN FD frame without flags nibble");
  EXPECT_EQ(Parse("(2.0) can0 123##1" + data + "00").error, "CAN FD payload longer than 64 bytes");
}

TEST(CandumpLine, ErrorFrameKeepsClassBitsWithoutErrFlag) {
  const Parsed p = Parse("(3.000000) can0 20000080#0000000000000000");
  ASSERT_EQ(p.error, "");
  EXPECT_TRUE(p.frame.error());
  EXPECT_FALSE(p.frame.extended());
  EXPECT_EQ(p.frame.id, 0x80u);  // CAN_ERR_BUSERROR
  EXPECT_EQ(p.frame.len, 8);
  EXPECT_EQ(Parse("(3.0) can0 A0000080#00").error, "error frame id has EFF/RTR bits");
}

TEST(CandumpLine, RawDlcHintIsAcceptedOnlyAfterEightBytes) {
  Parsed p = Parse("(1.0) can0 123#1122334455667788_9");
  ASSERT_EQ(p.error, "");
  EXPECT_EQ(p.frame.len, 8);
  EXPECT_EQ(Parse("(1.0) can0 123#11223344556677_9").error, "raw DLC after '_' needs 8 data bytes");
  EXPECT_EQ(Parse("(1.0) can0 123#1122334455667788_8").error, "bad raw DLC after '_'");
  EXPECT_EQ(Parse("(1.0) can0 123#1122334455667788_").error, "bad raw DLC after '_'");
}

TEST(CandumpLine, AcceptsDirectionTokenCrlfAndExtraBlanks) {
  EXPECT_EQ(Parse("(1.0) can0 123#01 R").error, "");
  EXPECT_EQ(Parse("(1.0) can0 123#01 T\r").error, "");
  EXPECT_EQ(Parse("(1.0)\tcan0   123#01  ").error, "");
  EXPECT_EQ(Parse("(1.0) can0 123#01 X").error, "unexpected text after frame");
  EXPECT_EQ(Parse("(1.0) can0 123#01 R extra").error, "unexpected text after frame");
}

TEST(CandumpLine, RejectsEachKindOfMalformedLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "empty line"},
      {"1.0 can0 123#00", "missing '(' before timestamp"},
      {"(.5) can0 123#00", "missing timestamp seconds"},
      {"(1) can0 123#00", "timestamp without '.' fraction"},
      {"(1.) can0 123#00", "missing timestamp fraction"},
      {"(1.5 can0 123#00", "missing ')' after timestamp"},
      {"(1.5x) can0 123#00", "missing ')' after timestamp"},
      {"(1.5)can0 123#00", "missing blank after timestamp"},
      {"(1.5) ", "missing blank after timestamp"},  // trailing blanks are trimmed
      {"(1.5) can0", "missing frame after interface name"},
      {"(1.5) averyveryverylongname0 123#00", "interface name longer than 15 characters"},
      {"(1.5) can0 12300", "missing '#' between id and data"},
      {"(1.5) can0 1234#00", "id must have 3 or 8 hex digits"},
      {"(1.5) can0 #00", "id must have 3 or 8 hex digits"},
      {"(1.5) can0 12G#00", "bad hex digit in id"},
      {"(1.5) can0 800#00", "standard id exceeds 0x7FF"},
      {"(1.5) can0 40000000#00", "extended id exceeds 29 bits"},
      {"(1.5) can0 123#ABC", "odd number of hex digits in data"},
      {"(1.5) can0 123#ZZ", "bad hex digit in data"},
      {"(1.5) can0 123#001122334455667788", "classic CAN payload longer than 8 bytes"},
      {"(1.5) can0 123#11.22", "odd number of hex digits in data"},
  };
  for (const auto& [line, reason] : cases) {
    EXPECT_EQ(Parse(line).error, reason) << "line: " << line;
  }
}

TEST(CandumpLine, FormatWritesCandumpStyle) {
  CanFrame f;
  f.timestamp_ns = 1700000000123456000;
  f.id = 0x25;
  f.len = 3;
  f.data = {0x0F, 0xFD, 0x10};
  EXPECT_EQ(FormatCandumpLine(f, "can0"), "(1700000000.123456) can0 025#0FFD10");
  f.flags = kFlagExtended;
  EXPECT_EQ(FormatCandumpLine(f, "can1"), "(1700000000.123456) can1 00000025#0FFD10");
  f.flags = kFlagRemote;
  EXPECT_EQ(FormatCandumpLine(f, "can0"), "(1700000000.123456) can0 025#R3");
  f.flags = kFlagFd | kFlagFdBrs;
  EXPECT_EQ(FormatCandumpLine(f, "can0"), "(1700000000.123456) can0 025##10FFD10");
  f.flags = kFlagError;
  f.id = 0x40;
  f.len = 0;
  EXPECT_EQ(FormatCandumpLine(f, "can0"), "(1700000000.123456) can0 20000040#");
  f.timestamp_ns = 1000000001;
  EXPECT_EQ(FormatCandumpLine(f, "can0"), "(1.000000001) can0 20000040#")
      << "sub-microsecond times need nine digits to round-trip";
}

// Random frames of every kind survive Format -> Parse unchanged (fixed seed: reproducible).
TEST(CandumpLine, RandomFramesRoundTripExactly) {
  std::mt19937_64 rng(20240611);
  const int fd_lengths[] = {0, 1, 5, 8, 12, 16, 20, 24, 32, 48, 64};
  for (int i = 0; i < 20000; ++i) {
    CanFrame f;
    f.timestamp_ns = static_cast<int64_t>(rng() % 4000000000000000000ull);
    if (rng() % 2) f.timestamp_ns -= f.timestamp_ns % 1000;
    const int kind = static_cast<int>(rng() % 5);
    const bool extended = rng() % 2;
    f.id = static_cast<uint32_t>(rng()) & (extended ? kExtendedIdMask : kStandardIdMask);
    f.flags = extended ? kFlagExtended : 0;
    if (kind == 0) {
      f.flags |= kFlagRemote;
      f.len = static_cast<uint8_t>(rng() % 9);
    } else if (kind == 1) {
      f.flags |= kFlagFd | (rng() % 2 ? kFlagFdBrs : 0) | (rng() % 2 ? kFlagFdEsi : 0);
      f.len = static_cast<uint8_t>(fd_lengths[rng() % 11]);
    } else if (kind == 2) {
      f.flags = kFlagError;
      f.id = static_cast<uint32_t>(rng()) & 0x3FF;
      f.len = 8;
    } else {
      f.len = static_cast<uint8_t>(rng() % 9);
    }
    if (!f.remote()) {
      for (int b = 0; b < f.len; ++b) f.data[b] = static_cast<uint8_t>(rng());
    }
    const std::string line = FormatCandumpLine(f, "can" + std::to_string(i % 3));
    const Parsed p = Parse(line);
    ASSERT_EQ(p.error, "") << line;
    EXPECT_EQ(p.frame.timestamp_ns, f.timestamp_ns) << line;
    EXPECT_EQ(p.frame.id, f.id) << line;
    EXPECT_EQ(p.frame.flags, f.flags) << line;
    EXPECT_EQ(p.frame.len, f.len) << line;
    EXPECT_EQ(p.frame.data, f.data) << line;
    EXPECT_EQ(p.bus, "can" + std::to_string(i % 3));
    EXPECT_EQ(FormatCandumpLine(p.frame, p.bus), line);
  }
}

}  // namespace
}  // namespace ndsid::can
