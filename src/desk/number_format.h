// Fast, exact number formatting for the desk's CSV writers.
#pragma once

#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>

namespace ndsid::desk {

// Writes `v` exactly as printf("%.10g") would (the format `ndsid decode` has always used): whole
// numbers below 1e10 (flags, counters, zeros: most of a bus) as integers; short decimals (a raw
// value times a DBC factor) from their integer digits; the rest from the
// shortest round-trip digits (to_chars without a precision, several times faster than with
// one), rounded to 10 significant digits. That rounding equals printf's rounding of the exact
// binary value except when the digits beyond the tenth are exactly "5" (the shortest digits then
// sit on the tie, and the exact value may lie on either side): those few values, subnormal
// and non-finite ones go through to_chars with a precision, which the standard defines as printf's
// conversion without its format parsing and locale. `p` needs 32 bytes; returns the end.
inline char* FormatG10(char* p, double v) {
  if (std::abs(v) < 1e10 && v == std::trunc(v)) {
    if (v == 0 && std::signbit(v)) {  // %g keeps the sign of -0
      *p++ = '-';
      *p++ = '0';
      return p;
    }
    return std::to_chars(p, p + 32, static_cast<int64_t>(v)).ptr;
  }
  // Short decimals, what a DBC factor makes of a raw value (raw * 0.01, raw * 0.0625 - 40): v
  // within 1e-12 (relative) of a decimal D of at most 10 significant digits, 1e-4 <= |D| < 1e10.
  // printf's rounding of v to 10 significant digits is then D itself (half a unit of the 10th
  // digit is at least 5e-11 of the value, far beyond v's distance from D), and %g prints D in
  // fixed notation without trailing zeros: its digits, straight from the integer D * 10^k.
  {
    const double a = std::abs(v);
    if (a >= 1e-4 && a < 1e10) {
      double scale = 1;
      for (int k = 1; k <= 14; ++k) {
        scale *= 10;  // 10^k, exact
        const double m = a * scale;
        if (m >= 1e10) break;  // D would need more than 10 digits
        const double r = static_cast<double>(static_cast<int64_t>(m + 0.5));
        if (!(std::abs(m - r) <= 1e-12 * m) || r < 1 || r >= 1e10) continue;
        uint64_t digits = static_cast<uint64_t>(r);
        int decimals = k;
        while (decimals > 0 && digits % 10 == 0) {
          digits /= 10;
          --decimals;
        }
        uint64_t pow10 = 1;
        for (int i = 0; i < decimals; ++i) pow10 *= 10;
        if (v < 0) *p++ = '-';
        p = std::to_chars(p, p + 24, digits / pow10).ptr;
        if (decimals > 0) {
          *p++ = '.';
          uint64_t frac = digits % pow10;
          for (int i = decimals - 1; i >= 0; --i) {
            p[i] = static_cast<char>('0' + frac % 10);
            frac /= 10;
          }
          p += decimals;
        }
        return p;
      }
    }
  }
  // Non-finite values, and subnormals (their few bits leave the shortest digits far from the exact value).
  if (!std::isfinite(v) || std::abs(v) < std::numeric_limits<double>::min())
    return std::to_chars(p, p + 32, v, std::chars_format::general, 10).ptr;
  // Shortest digits in scientific form: [-]d[.ddd]e(+|-)XX[X]
  char s[40];
  const char* const end = std::to_chars(s, s + sizeof s, v, std::chars_format::scientific).ptr;
  const char* q = s;
  const bool negative = *q == '-';
  if (negative) ++q;
  char digits[20];
  int n = 0;
  for (; q < end && *q != 'e'; ++q)
    if (*q != '.') digits[n++] = *q;
  int exp10 = 0;
  {
    const char* e = q + 1;
    const bool exp_negative = *e == '-';
    ++e;
    for (; e < end; ++e) exp10 = exp10 * 10 + (*e - '0');
    if (exp_negative) exp10 = -exp10;
  }
  if (n > 10) {
    if (n == 11 && digits[10] == '5')  // a tie of the shortest digits: the exact value decides
      return std::to_chars(p, p + 32, v, std::chars_format::general, 10).ptr;
    const bool up = digits[10] >= '5';
    n = 10;
    if (up) {
      int i = n - 1;
      while (i >= 0 && digits[i] == '9') digits[i--] = '0';
      if (i >= 0) {
        ++digits[i];
      } else {  // 9.999999999|9 -> 10.00000000
        digits[0] = '1';
        ++exp10;
      }
    }
  }
  while (n > 1 && digits[n - 1] == '0') --n;  // %g drops trailing zeros
  if (negative) *p++ = '-';
  if (exp10 < -4 || exp10 >= 10) {  // %g's scientific form: d[.ddd]e(+|-)XX
    *p++ = digits[0];
    if (n > 1) {
      *p++ = '.';
      for (int i = 1; i < n; ++i) *p++ = digits[i];
    }
    *p++ = 'e';
    *p++ = exp10 < 0 ? '-' : '+';
    const int a = exp10 < 0 ? -exp10 : exp10;
    if (a >= 100) *p++ = static_cast<char>('0' + a / 100);
    *p++ = static_cast<char>('0' + a / 10 % 10);
    *p++ = static_cast<char>('0' + a % 10);
    return p;
  }
  if (exp10 < 0) {  // 0.000ddd
    *p++ = '0';
    *p++ = '.';
    for (int i = -1; i > exp10; --i) *p++ = '0';
    for (int i = 0; i < n; ++i) *p++ = digits[i];
    return p;
  }
  for (int i = 0; i <= exp10; ++i) *p++ = i < n ? digits[i] : '0';  // the whole part
  if (n > exp10 + 1) {
    *p++ = '.';
    for (int i = exp10 + 1; i < n; ++i) *p++ = digits[i];
  }
  return p;
}

}  // namespace ndsid::desk
