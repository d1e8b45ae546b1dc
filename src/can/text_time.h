// Small parsers shared by the text formats: decimal seconds to nanoseconds, calendar dates.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace ndsid::can::detail {

// "12.345678" (digits, optional fraction, up to 9 fraction digits used) -> nanoseconds.
std::optional<int64_t> ParseSecondsNs(std::string_view text) noexcept;

// Nanoseconds since 1970 of a UTC calendar time; nullopt when out of range.
std::optional<int64_t> CivilToNs(int year, int month, int day, int hour, int minute, int second,
                                 int64_t nanosecond) noexcept;

// An ASC header date after the weekday, e.g. "Nov 23 08:00:00.000 am 2026" or
// "Nov 23 20:00:00.123 2026" (German month abbreviations accepted), read as UTC. A fraction
// of fewer than three digits is a count of milliseconds (python-can writes ".4" for 4 ms).
std::optional<int64_t> ParseAscDateNs(std::string_view text) noexcept;

}  // namespace ndsid::can::detail
