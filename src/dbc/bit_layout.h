// Where a signal's bits sit in a payload, in the DBC numbering: payload bit p is bit p % 8
// (0 = least significant) of byte p / 8. Intel (@1) signals occupy start .. start+length-1,
// least significant bit first. Motorola (@0) signals start at their most significant bit and
// walk down within a byte, continuing at bit 7 of the next byte (the DBC "sawtooth").
// Private to the dbc stage; the decoder uses its own byte-wise plan, tested against this.
#pragma once

#include <cstdint>

#include "ndsid/dbc/database.h"

namespace ndsid::dbc::internal {

inline constexpr uint32_t kMaxPayloadBits = 64 * 8;  // CAN FD

// Calls visit(payload_bit, value_bit) for every bit of the signal, most significant value bit
// first for Motorola and least significant first for Intel. Returns false (having stopped)
// as soon as a bit would lie beyond a 64-byte payload.
template <typename Visit>
bool ForEachSignalBit(const Signal& signal, Visit&& visit) {
  uint32_t pos = signal.start_bit;
  for (uint32_t i = 0; i < signal.length; ++i) {
    if (pos >= kMaxPayloadBits) return false;
    if (signal.byte_order == ByteOrder::kLittleEndian) {
      visit(pos, i);
      ++pos;
    } else {
      visit(pos, signal.length - 1 - i);
      pos = (pos % 8 == 0) ? pos + 15 : pos - 1;
    }
  }
  return true;
}

// Bytes needed to hold the signal, or 0 if it does not fit in 64 bytes.
inline uint32_t SignalRequiredBytes(const Signal& signal) {
  uint32_t highest = 0;
  const bool fits = ForEachSignalBit(signal, [&](uint32_t pos, uint32_t) {
    if (pos > highest) highest = pos;
  });
  return fits && signal.length > 0 ? highest / 8 + 1 : 0;
}

}  // namespace ndsid::dbc::internal
