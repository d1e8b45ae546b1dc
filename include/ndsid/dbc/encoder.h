// Physical value -> raw bits in a payload: the inverse of the decoder, used by the simulator
// to write what a real bus would carry and by the decoder's round-trip tests.
#pragma once

#include <cstdint>
#include <span>

#include "ndsid/dbc/database.h"

namespace ndsid::dbc {

// Raw integer for a physical value: round((physical - offset) / factor) (half away from zero),
// saturated to the signal's raw range; NaN gives 0; a 64-bit unsigned signal saturates at
// INT64_MAX. For float signals it returns the IEEE bit pattern of (physical - offset) / factor
// (float32 in the low 32 bits).
int64_t PhysicalToRaw(const Signal& signal, double physical);

// Writes `physical` into the signal's bits of `payload` (other bits untouched).
// payload.size() must cover the signal, else ndsid::Error is thrown (a caller's bug).
void EncodeSignal(const Signal& signal, double physical, std::span<uint8_t> payload);

// Writes a raw value (two's complement for signed signals; bits above the length are ignored)
// into the signal's bits. Throws ndsid::Error like EncodeSignal.
void EncodeRaw(const Signal& signal, uint64_t raw, std::span<uint8_t> payload);

// Bytes a payload needs to hold the signal (its highest bit's byte + 1).
uint32_t RequiredBytes(const Signal& signal);

}  // namespace ndsid::dbc
