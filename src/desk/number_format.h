// Fast, exact number formatting for the desk's CSV writers.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>

namespace ndsid::desk {

// Writes `v` exactly as printf("%.10g") would (the format `ndsid decode` has always used): whole
// numbers below 1e10 (flags, counters, zeros: most of a bus) as integers, the rest through
// to_chars with a precision, which the standard defines as printf's conversion without its
// format parsing and locale. `p` needs 32 bytes; returns the end.
inline char* FormatG10(char* p, double v) {
  if (std::abs(v) < 1e10 && v == std::trunc(v)) {
    if (v == 0 && std::signbit(v)) {  // %g keeps the sign of -0
      *p++ = '-';
      *p++ = '0';
      return p;
    }
    return std::to_chars(p, p + 32, static_cast<int64_t>(v)).ptr;
  }
  return std::to_chars(p, p + 32, v, std::chars_format::general, 10).ptr;
}

}  // namespace ndsid::desk
