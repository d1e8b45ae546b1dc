// Encoder: round trip through the decoder over every signal of the example DBC, rounding,
// saturation, untouched neighbouring bits, and a real RAV4 frame rebuilt bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"
#include "ndsid/dbc/encoder.h"

namespace ndsid::dbc {
namespace {

Signal MakeSignal(uint32_t start, uint32_t length, ByteOrder order, ValueType type, double factor = 1, double offset = 0) {
  Signal s;
  s.name = "S";
  s.start_bit = start;
  s.length = length;
  s.byte_order = order;
  s.value_type = type;
  s.factor = factor;
  s.offset = offset;
  return s;
}

// Bits of the payload that belong to the signal.
std::vector<uint8_t> SignalMask(const Signal& s, size_t size) {
  std::vector<uint8_t> mask(size, 0);
  EncodeRaw(s, ~uint64_t{0}, mask);
  return mask;
}

TEST(Encoder, RoundTripsRandomPhysicalValuesOverEveryExampleSignal) {
  const Database db = ParseDbcFile(NDSID_SOURCE_DIR "/dbc/ndsid_example.dbc");
  const Decoder decoder(db);
  std::mt19937_64 rng(7);
  std::vector<DecodedValue> out(decoder.max_signals_per_message());
  int checked = 0;
  for (const auto& m : db.messages) {
    for (const auto& s : m.signals) {
      const double lo = s.minimum;
      const double hi = s.maximum > s.minimum ? s.maximum : s.minimum + s.factor * 100;
      std::uniform_real_distribution<double> physical(lo, hi);
      for (int k = 0; k < 200; ++k) {
        const double value = physical(rng);
        can::CanFrame frame;
        frame.id = m.id;
        frame.flags = m.extended ? can::kFlagExtended : 0;
        frame.len = static_cast<uint8_t>(m.length);
        for (auto& b : frame.data) b = static_cast<uint8_t>(rng());
        if (s.mux_role == MuxRole::kMultiplexed) EncodeRaw(*m.Multiplexor(), s.mux_value, {frame.data.data(), m.length});
        const auto before = frame.data;
        EncodeSignal(s, value, {frame.data.data(), m.length});

        const auto mask = SignalMask(s, m.length);
        for (uint32_t i = 0; i < m.length; ++i) {
          ASSERT_EQ((frame.data[i] ^ before[i]) & ~mask[i], 0) << s.name << ": bits outside the signal changed";
        }
        size_t count = 0;
        decoder.Decode(frame, out, count);
        const int index = decoder.SignalIndex(m.name, s.name);
        bool found = false;
        for (size_t i = 0; i < count; ++i) {
          if (out[i].signal_index != index) continue;
          found = true;
          const double tolerance = s.is_float() ? std::abs(value) * 1e-7 : std::abs(s.factor) / 2 * (1 + 1e-9);
          EXPECT_NEAR(out[i].value, value, tolerance) << m.name << "." << s.name;
        }
        ASSERT_TRUE(found) << m.name << "." << s.name;
        ++checked;
      }
    }
  }
  EXPECT_EQ(checked, 32 * 200);
}

TEST(Encoder, RoundsToNearestHalfAwayFromZero) {
  const Signal s = MakeSignal(0, 8, ByteOrder::kLittleEndian, ValueType::kSigned, 0.5, 0);
  EXPECT_EQ(PhysicalToRaw(s, 0.25), 1);
  EXPECT_EQ(PhysicalToRaw(s, -0.25), -1);
  EXPECT_EQ(PhysicalToRaw(s, 0.74), 1);
  const Signal offset = MakeSignal(0, 16, ByteOrder::kLittleEndian, ValueType::kUnsigned, 0.01, -67.67);
  EXPECT_EQ(PhysicalToRaw(offset, 71.24), 13891);  // RAV4 WHEEL_SPEED_FR from the README
}

TEST(Encoder, SaturatesToTheRawRange) {
  const Signal u = MakeSignal(0, 12, ByteOrder::kLittleEndian, ValueType::kUnsigned);
  EXPECT_EQ(PhysicalToRaw(u, 5000), 4095);
  EXPECT_EQ(PhysicalToRaw(u, -3), 0);
  const Signal s = MakeSignal(0, 12, ByteOrder::kBigEndian, ValueType::kSigned);
  EXPECT_EQ(PhysicalToRaw(s, 5000), 2047);
  EXPECT_EQ(PhysicalToRaw(s, -5000), -2048);
  const Signal s64 = MakeSignal(0, 64, ByteOrder::kLittleEndian, ValueType::kSigned);
  EXPECT_EQ(PhysicalToRaw(s64, 1e30), std::numeric_limits<int64_t>::max());
  EXPECT_EQ(PhysicalToRaw(s64, -1e30), std::numeric_limits<int64_t>::min());
  EXPECT_EQ(PhysicalToRaw(u, std::numeric_limits<double>::infinity()), 4095);
  EXPECT_EQ(PhysicalToRaw(u, std::nan("")), 0);
}

TEST(Encoder, FloatSignalsCarryTheIeeeBitPattern) {
  const Signal f = MakeSignal(0, 32, ByteOrder::kLittleEndian, ValueType::kFloat32, 2, 1);
  EXPECT_EQ(PhysicalToRaw(f, 26.0), 0x41480000);  // (26 - 1) / 2 = 12.5f
  std::vector<uint8_t> payload(4);
  EncodeSignal(f, 26.0, payload);
  EXPECT_EQ(payload, (std::vector<uint8_t>{0x00, 0x00, 0x48, 0x41}));
}

TEST(Encoder, RebuildsARealRav4FrameBitForBit) {
  // (46418.382980) can0 025#0FFD1000FFFD0045 -> STEER_ANGLE=-4.5, STEER_FRACTION=-0.1, STEER_RATE=-3
  const Database db = ParseDbcText(R"(BO_ 37 STEER_ANGLE_SENSOR: 8 XXX
 SG_ STEER_ANGLE : 3|12@0- (1.5,0) [-500|500] "deg" XXX
 SG_ STEER_FRACTION : 39|4@0- (0.1,0) [-0.7|0.7] "deg" XXX
 SG_ STEER_RATE : 35|12@0- (1,0) [-2000|2000] "deg/s" XXX
)", "toyota.dbc");
  const std::vector<uint8_t> real = {0x0F, 0xFD, 0x10, 0x00, 0xFF, 0xFD, 0x00, 0x45};
  std::vector<uint8_t> payload = real;
  const Message& m = db.messages.at(0);
  for (const auto& s : m.signals) {
    const auto mask = SignalMask(s, 8);
    for (size_t i = 0; i < 8; ++i) payload[i] &= static_cast<uint8_t>(~mask[i]);  // clear the signal's bits
  }
  EncodeSignal(*m.FindSignal("STEER_ANGLE"), -4.5, payload);
  EncodeSignal(*m.FindSignal("STEER_FRACTION"), -0.1, payload);
  EncodeSignal(*m.FindSignal("STEER_RATE"), -3, payload);
  EXPECT_EQ(payload, real);
}

TEST(Encoder, IgnoresRawBitsAboveTheSignalLength) {
  const Signal s = MakeSignal(4, 4, ByteOrder::kLittleEndian, ValueType::kUnsigned);
  std::vector<uint8_t> payload = {0x0A, 0xFF};
  EncodeRaw(s, 0xF5, payload);
  EXPECT_EQ(payload, (std::vector<uint8_t>{0x5A, 0xFF}));
}

TEST(Encoder, ThrowsWhenThePayloadCannotHoldTheSignal) {
  const Signal s = MakeSignal(7, 16, ByteOrder::kBigEndian, ValueType::kUnsigned);
  EXPECT_EQ(RequiredBytes(s), 2u);
  std::vector<uint8_t> payload(1);
  EXPECT_THROW(EncodeSignal(s, 1, payload), Error);
}

}  // namespace
}  // namespace ndsid::dbc
