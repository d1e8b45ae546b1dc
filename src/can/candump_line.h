// Allocation-free candump line parsing shared by CandumpReader and ParseCandumpLine.
#pragma once

#include <string_view>

#include "ndsid/can/can_frame.h"

namespace ndsid::can::detail {

// Returns nullptr on success, else a static string with the reason the line is malformed.
const char* ParseLine(std::string_view line, CanFrame& frame, std::string_view& bus_name) noexcept;

// True for a line the reader skips: empty, only blanks, or a comment starting with '#'.
bool IsBlankOrComment(std::string_view line) noexcept;

// True when `len` is a CAN FD payload length a DLC can express (0..8, 12, 16, 20, 24, 32, 48, 64).
constexpr bool IsValidFdLength(int len) {
  return (len >= 0 && len <= 8) || len == 12 || len == 16 || len == 20 || len == 24 ||
         len == 32 || len == 48 || len == 64;
}

}  // namespace ndsid::can::detail
