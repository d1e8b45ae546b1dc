// The encoder walks the signal bit by bit (bit_layout.h), independently of the decoder's
// byte-wise plans, so that the round-trip tests compare two different implementations.
#include "ndsid/dbc/encoder.h"

#include <bit>
#include <cmath>
#include <limits>
#include <string>

#include "bit_layout.h"
#include "ndsid/common/error.h"

namespace ndsid::dbc {
namespace {

void CheckCovers(const Signal& signal, std::span<uint8_t> payload) {
  const uint32_t needed = internal::SignalRequiredBytes(signal);
  if (needed == 0 || payload.size() < needed) {
    throw Error("encoding signal " + signal.name + " needs a " + std::to_string(needed) + "-byte payload, got " +
                std::to_string(payload.size()) + " bytes");
  }
}

}  // namespace

int64_t PhysicalToRaw(const Signal& signal, double physical) {
  const double scaled = signal.factor != 0.0 ? (physical - signal.offset) / signal.factor : 0.0;
  if (signal.value_type == ValueType::kFloat32) {
    return static_cast<int64_t>(std::bit_cast<uint32_t>(static_cast<float>(scaled)));
  }
  if (signal.value_type == ValueType::kFloat64) return std::bit_cast<int64_t>(scaled);
  if (std::isnan(scaled)) return 0;
  // The raw range as doubles; 2^63 itself is not representable in int64, hence the >= tests.
  const uint32_t n = signal.length;
  const double two_63 = 9223372036854775808.0;
  double lo = 0.0;
  double hi = 0.0;
  if (signal.value_type == ValueType::kSigned) {
    lo = -std::ldexp(1.0, static_cast<int>(n) - 1);
    hi = std::ldexp(1.0, static_cast<int>(n) - 1) - 1.0;
  } else {
    hi = n >= 63 ? two_63 : std::ldexp(1.0, static_cast<int>(n)) - 1.0;
  }
  const double rounded = std::round(scaled);
  if (rounded <= lo) return static_cast<int64_t>(lo);  // -2^(n-1) or 0, both exact
  if (rounded >= hi) {
    if (hi >= two_63) return std::numeric_limits<int64_t>::max();
    return static_cast<int64_t>(hi);
  }
  return static_cast<int64_t>(rounded);
}

void EncodeRaw(const Signal& signal, uint64_t raw, std::span<uint8_t> payload) {
  CheckCovers(signal, payload);
  internal::ForEachSignalBit(signal, [&](uint32_t pos, uint32_t value_bit) {
    const auto bit = static_cast<uint8_t>(1u << (pos % 8));
    if ((raw >> value_bit) & 1u) {
      payload[pos / 8] |= bit;
    } else {
      payload[pos / 8] &= static_cast<uint8_t>(~bit);
    }
  });
}

void EncodeSignal(const Signal& signal, double physical, std::span<uint8_t> payload) {
  EncodeRaw(signal, static_cast<uint64_t>(PhysicalToRaw(signal, physical)), payload);
}

uint32_t RequiredBytes(const Signal& signal) { return internal::SignalRequiredBytes(signal); }

}  // namespace ndsid::dbc
