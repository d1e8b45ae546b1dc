// Physical value -> raw bits in a payload: the inverse of the decoder, used by the simulator
// to write what a real bus would carry and by the decoder's round-trip tests.
#pragma once

#include <cstdint>
#include <span>

#include "ndsid/dbc/database.h"

namespace ndsid::dbc {

// Raw integer for a physical value: round((physical - offset) / factor), saturated to the
// signal's raw range. For float signals, use EncodeSignal directly.
int64_t PhysicalToRaw(const Signal& signal, double physical);

// Writes `physical` into the signal's bits of `payload` (other bits untouched).
// payload.size() must cover the signal.
void EncodeSignal(const Signal& signal, double physical, std::span<uint8_t> payload);

// Writes a raw value (two's complement for signed signals) into the signal's bits.
void EncodeRaw(const Signal& signal, uint64_t raw, std::span<uint8_t> payload);

}  // namespace ndsid::dbc
