// A deliberately naive reference decoder for tests: walks a signal bit by bit, straight from
// the DBC definition (Intel: start bit is the LSB, bits ascend; Motorola: start bit is the MSB,
// bits descend within a byte and continue at bit 7 of the next byte). It shares no code with
// src/dbc, so the decoder's byte-wise plans are checked against an independent reading.
#pragma once

#include <bit>
#include <cstdint>
#include <optional>
#include <span>

#include "ndsid/dbc/database.h"

namespace ndsid::dbc::testing {

// Raw bits of the signal (unsigned, not sign-extended), or nullopt if the payload is too short.
inline std::optional<uint64_t> NaiveRaw(const Signal& s, std::span<const uint8_t> payload) {
  uint64_t raw = 0;
  int pos = static_cast<int>(s.start_bit);
  for (uint32_t i = 0; i < s.length; ++i) {
    if (pos / 8 >= static_cast<int>(payload.size())) return std::nullopt;
    const uint64_t bit = (payload[static_cast<size_t>(pos / 8)] >> (pos % 8)) & 1u;
    if (s.byte_order == ByteOrder::kLittleEndian) {
      raw |= bit << i;
      ++pos;
    } else {
      raw = (raw << 1) | bit;
      pos = (pos % 8 == 0) ? pos + 15 : pos - 1;
    }
  }
  return raw;
}

inline std::optional<double> NaivePhysical(const Signal& s, std::span<const uint8_t> payload) {
  const auto raw = NaiveRaw(s, payload);
  if (!raw) return std::nullopt;
  double value = 0;
  switch (s.value_type) {
    case ValueType::kUnsigned: value = static_cast<double>(*raw); break;
    case ValueType::kSigned: {
      const bool negative = s.length < 64 ? ((*raw >> (s.length - 1)) & 1u) != 0 : static_cast<int64_t>(*raw) < 0;
      value = negative && s.length < 64 ? -static_cast<double>((uint64_t{1} << s.length) - *raw)
                                        : static_cast<double>(static_cast<int64_t>(*raw));
      break;
    }
    case ValueType::kFloat32: value = std::bit_cast<float>(static_cast<uint32_t>(*raw)); break;
    case ValueType::kFloat64: value = std::bit_cast<double>(*raw); break;
  }
  return value * s.factor + s.offset;
}

}  // namespace ndsid::dbc::testing
