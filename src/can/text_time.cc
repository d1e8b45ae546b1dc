#include "text_time.h"

#include <array>
#include <cctype>
#include <string>

namespace ndsid::can::detail {

std::optional<int64_t> ParseSecondsNs(std::string_view text) noexcept {
  size_t i = 0;
  int64_t seconds = 0;
  if (text.empty()) return std::nullopt;
  for (; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i) {
    seconds = seconds * 10 + (text[i] - '0');
    if (seconds > 9'000'000'000LL) return std::nullopt;  // beyond ~285 years: int64 ns overflow
  }
  if (i == 0) return std::nullopt;
  int64_t fraction = 0;
  int digits = 0;
  if (i < text.size()) {
    if (text[i] != '.') return std::nullopt;
    for (++i; i < text.size(); ++i) {
      if (text[i] < '0' || text[i] > '9') return std::nullopt;
      if (digits < 9) {
        fraction = fraction * 10 + (text[i] - '0');
        ++digits;
      }
    }
  }
  for (; digits < 9; ++digits) fraction *= 10;
  return seconds * 1'000'000'000LL + fraction;
}

std::optional<int64_t> CivilToNs(int year, int month, int day, int hour, int minute, int second,
                                 int64_t nanosecond) noexcept {
  if (year < 1970 || year > 2200 || month < 1 || month > 12 || day < 1 || day > 31 || hour < 0 ||
      hour > 23 || minute < 0 || minute > 59 || second < 0 || second > 60 || nanosecond < 0 ||
      nanosecond >= 1'000'000'000LL) {
    return std::nullopt;
  }
  // Days from civil (H. Hinnant's algorithm), proleptic Gregorian.
  const int y = year - (month <= 2 ? 1 : 0);
  const int era = y / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (month + (month > 2 ? -3 : 9)) + 2) / 5 + day - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  const int64_t days = static_cast<int64_t>(era) * 146097 + doe - 719468;
  return ((days * 24 + hour) * 60 + minute) * 60'000'000'000LL + second * 1'000'000'000LL + nanosecond;
}

namespace {

int MonthNumber(std::string_view name) noexcept {
  static constexpr std::array<std::pair<std::string_view, int>, 16> kMonths = {{
      {"jan", 1}, {"feb", 2}, {"mar", 3}, {"apr", 4}, {"may", 5}, {"jun", 6}, {"jul", 7}, {"aug", 8},
      {"sep", 9}, {"oct", 10}, {"nov", 11}, {"dec", 12}, {"m\xc3\xa4r", 3}, {"mai", 5}, {"okt", 10}, {"dez", 12}}};
  std::string lower(name.substr(0, 8));
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const auto& [text, number] : kMonths) {
    if (lower == text) return number;
  }
  return 0;
}

bool ParseInt(std::string_view s, int& out) noexcept {
  if (s.empty() || s.size() > 6) return false;
  out = 0;
  for (const char c : s) {
    if (c < '0' || c > '9') return false;
    out = out * 10 + (c - '0');
  }
  return true;
}

}  // namespace

std::optional<int64_t> ParseAscDateNs(std::string_view text) noexcept {
  std::string_view tokens[6];
  size_t count = 0;
  size_t i = 0;
  while (i < text.size() && count < 6) {
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    const size_t start = i;
    while (i < text.size() && text[i] != ' ' && text[i] != '\t') ++i;
    if (i > start) tokens[count++] = text.substr(start, i - start);
  }
  if (count < 4) return std::nullopt;
  const int month = MonthNumber(tokens[0]);
  int day = 0, year = 0;
  if (month == 0 || !ParseInt(tokens[1], day)) return std::nullopt;
  // hh:mm:ss[.fff]
  const std::string_view clock = tokens[2];
  int hour = 0, minute = 0, second = 0;
  if (clock.size() < 8 || clock[2] != ':' || clock[5] != ':' || !ParseInt(clock.substr(0, 2), hour) ||
      !ParseInt(clock.substr(3, 2), minute) || !ParseInt(clock.substr(6, 2), second)) {
    return std::nullopt;
  }
  int64_t nanosecond = 0;
  if (clock.size() > 8) {
    if (clock[8] != '.' || clock.size() == 9) return std::nullopt;
    const std::string_view fraction = clock.substr(9);
    int64_t scale = 100'000'000;
    for (const char c : fraction) {
      if (c < '0' || c > '9') return std::nullopt;
      nanosecond += (c - '0') * scale;
      scale /= 10;
    }
    // Vector writes three digits. python-can (to 4.6 at least) writes the milliseconds
    // unpadded (".4" for 4 ms): a shorter field is a count of milliseconds.
    if (fraction.size() < 3) {
      int ms = 0;
      ParseInt(fraction, ms);
      nanosecond = int64_t{ms} * 1'000'000;
    }
  }
  size_t next = 3;
  if (count > 4) {  // "am" / "pm"
    const std::string_view ampm = tokens[3];
    const bool pm = ampm == "pm" || ampm == "PM";
    const bool am = ampm == "am" || ampm == "AM";
    if (!pm && !am) return std::nullopt;
    if (hour < 1 || hour > 12) return std::nullopt;
    hour = hour % 12 + (pm ? 12 : 0);
    next = 4;
  }
  if (!ParseInt(tokens[next], year)) return std::nullopt;
  return CivilToNs(year, month, day, hour, minute, second, nanosecond);
}

}  // namespace ndsid::can::detail
