// FormatG10 must print exactly what printf("%.10g") prints (the CSV of `ndsid decode` is
// byte-identical to what it was before the fast path): checked on the values a bus carries
// (raw × factor + offset of every width and scale) and on random doubles of every magnitude.
#include "number_format.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

namespace ndsid::desk {
namespace {

std::string Fast(double v) {
  char b[40];
  return std::string(b, FormatG10(b, v));
}

std::string Printf(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.10g", v);
  return b;
}

TEST(FormatG10, EqualsPrintfOnEdgeValues) {
  for (double v : {0.0, -0.0, 1.0, -1.0, 0.1, 0.3, 1e-5, 1e-4, 9999999999.0, 1e10, -1e10, 12345678901.0, 1e300,
                   -1e-300, std::numeric_limits<double>::denorm_min(), 3.3e-310, std::numeric_limits<double>::min(), std::numeric_limits<double>::max(),
                   std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(Fast(v), Printf(v)) << v;
  }
  EXPECT_EQ(Fast(std::numeric_limits<double>::quiet_NaN()), Printf(std::numeric_limits<double>::quiet_NaN()));
}

TEST(FormatG10, EqualsPrintfOnDbcScaledRawValues) {
  std::mt19937_64 rng(7);
  const double factors[] = {1, 0.1, 0.01, 0.001, 0.05, 0.0625, 1.0 / 3600, 0.000244140625, 3.6, 100};
  for (int i = 0; i < 200000; ++i) {
    const int bits = 1 + static_cast<int>(rng() % 32);
    const int64_t raw = static_cast<int64_t>(rng() % (uint64_t{1} << bits)) - (rng() % 2 ? (int64_t{1} << (bits - 1)) : 0);
    const double v = static_cast<double>(raw) * factors[rng() % 10] + (rng() % 3 ? 0.0 : -40.0);
    ASSERT_EQ(Fast(v), Printf(v)) << "raw " << raw;
  }
}

// The short-decimal path: decimals of 1 to 10 significant digits with 1 to 14 decimals, made
// the ways a decoder makes them (integer / 10^k, integer * 10^-k, raw * factor + offset), and
// the same values moved by 1e-13 .. 1e-9 of themselves (near a short decimal, but some too far
// to be one at 10 digits), on both sides of 1e-4 and 1e10.
TEST(FormatG10, EqualsPrintfOnShortDecimalsAndTheirNeighbours) {
  std::mt19937_64 rng(17);
  const double moves[] = {0, 1e-13, -1e-13, 2e-12, -5e-12, 3e-11, -4e-11, 1e-10, 1e-9};
  for (int i = 0; i < 300000; ++i) {
    const int digits = 1 + static_cast<int>(rng() % 10);
    uint64_t bound = 1;
    for (int d = 0; d < digits; ++d) bound *= 10;
    const double r = static_cast<double>(rng() % bound);
    const int k = 1 + static_cast<int>(rng() % 14);
    const double sign = rng() % 2 ? 1.0 : -1.0;
    const double by_division = sign * r / std::pow(10.0, k);
    const double by_product = sign * r * std::pow(10.0, -k);
    const double move = moves[rng() % 9];
    for (double v : {by_division, by_product, by_division * (1 + move), std::nextafter(by_product, 0.0)}) {
      ASSERT_EQ(Fast(v), Printf(v)) << r << "e-" << k << " moved " << move;
    }
  }
  for (double v : {1e-4, 0.00010000000001, 0.0001000000001, 9.999999999e-5, 9999999999.5, 999999999.95, 0.1 + 0.2,
                   -327.68, 0.3 - 0.1, 1.0 / 3.0, 2.0 / 3.0, 123456789.1, 12345678.91}) {
    EXPECT_EQ(Fast(v), Printf(v)) << v;
  }
}

TEST(FormatG10, EqualsPrintfOnRandomDoublesOfEveryMagnitude) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> mantissa(-10, 10);
  std::uniform_int_distribution<int> exponent(-30, 30);
  for (int i = 0; i < 200000; ++i) {
    const double v = mantissa(rng) * std::pow(10.0, exponent(rng));
    ASSERT_EQ(Fast(v), Printf(v)) << v;
    const double whole = std::trunc(v);
    ASSERT_EQ(Fast(whole), Printf(whole)) << whole;
  }
}

// Decimals of 11 and 12 significant digits: the 11-digit ones ending in 5 are the ties of the
// shortest digits, where only the exact binary value decides the rounding; the others round
// the shortest digits, with carries through nines (9.9999999995 -> 10).
TEST(FormatG10, EqualsPrintfOnTiesAndCarriesOfTheTenthDigit) {
  std::mt19937_64 rng(13);
  std::uniform_int_distribution<int> exponent(-25, 25);
  for (int i = 0; i < 200000; ++i) {
    const int64_t head = 1000000000 + static_cast<int64_t>(rng() % 9000000000ULL);  // 10 digits
    const int64_t tail = i % 3 == 0 ? 5 : static_cast<int64_t>(rng() % 100);
    const int64_t mantissa = i % 3 == 0 ? head * 10 + tail : head * 100 + tail;
    const double v = static_cast<double>(mantissa) * std::pow(10.0, exponent(rng)) * (i % 2 ? -1 : 1);
    ASSERT_EQ(Fast(v), Printf(v)) << mantissa;
    const double nines = (9999999999.0 + static_cast<double>(rng() % 2) * 0.5) * std::pow(10.0, exponent(rng) - 9);
    ASSERT_EQ(Fast(nines), Printf(nines)) << nines;
  }
}

}  // namespace
}  // namespace ndsid::desk
