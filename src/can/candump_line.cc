// candump log lines, as can-utils writes them (lib.c sprint_canframe, candump.c -l):
//   (1700000000.123456) can0 123#DEADBEEF          classic data, 3-digit standard id
//   (1700000000.123456) can0 1ABCDEF0#0102         8-digit extended id
//   (1700000000.123456) can0 123#R  / 123#R5        remote frame, optional DLC digit
//   (1700000000.123456) can0 123##1112233          CAN FD: flags nibble (BRS=1, ESI=2), data
//   (1700000000.123456) can0 20000080#00...        error frame (CAN_ERR_FLAG in the id)
// optionally followed by a direction token "R"/"T" (asc2log, newer candump).
#include <cstdio>
#include <cstring>
#include <string>

#include "candump_line.h"
#include "ndsid/can/candump_reader.h"

namespace ndsid::can {
namespace detail {
namespace {

constexpr uint32_t kCanErrFlag = 0x20000000u;  // CAN_ERR_FLAG of linux/can.h
constexpr int64_t kNsPerSecond = 1'000'000'000;
constexpr int64_t kMaxSeconds = INT64_MAX / kNsPerSecond - 1;
constexpr size_t kMaxBusNameChars = 15;  // IFNAMSIZ - 1

inline int HexValue(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

inline bool IsBlank(char c) noexcept { return c == ' ' || c == '\t'; }
inline bool IsDigit(char c) noexcept { return c >= '0' && c <= '9'; }

// Parses hex byte pairs from [p, end) into data; returns nullptr or the reason.
const char* ParseHexBytes(const char* p, const char* end, int max_bytes, uint8_t* data,
                          int& len) noexcept {
  const ptrdiff_t digits = end - p;
  if (digits % 2 != 0) return "odd number of hex digits in data";
  if (digits / 2 > max_bytes) {
    return max_bytes == 8 ? "classic CAN payload longer than 8 bytes"
                          : "CAN FD payload longer than 64 bytes";
  }
  len = static_cast<int>(digits / 2);
  for (int i = 0; i < len; ++i) {
    const int hi = HexValue(p[2 * i]);
    const int lo = HexValue(p[2 * i + 1]);
    if (hi < 0 || lo < 0) return "bad hex digit in data";
    data[i] = static_cast<uint8_t>(hi << 4 | lo);
  }
  return nullptr;
}

// The frame token "ID#..." in [p, end).
const char* ParseFrameToken(const char* p, const char* end, CanFrame& frame) noexcept {
  const char* hash = static_cast<const char*>(std::memchr(p, '#', end - p));
  if (hash == nullptr) return "missing '#' between id and data";
  const ptrdiff_t id_digits = hash - p;
  if (id_digits != 3 && id_digits != 8) return "id must have 3 or 8 hex digits";
  uint32_t id = 0;
  for (const char* q = p; q < hash; ++q) {
    const int v = HexValue(*q);
    if (v < 0) return "bad hex digit in id";
    id = id << 4 | static_cast<uint32_t>(v);
  }
  if (id_digits == 3) {
    if (id > kStandardIdMask) return "standard id exceeds 0x7FF";
    frame.id = id;
  } else if ((id & kCanErrFlag) != 0) {
    if ((id & ~(kCanErrFlag | kExtendedIdMask)) != 0) return "error frame id has EFF/RTR bits";
    frame.id = id & kExtendedIdMask;
    frame.flags = kFlagError;
  } else {
    if (id > kExtendedIdMask) return "extended id exceeds 29 bits";
    frame.id = id;
    frame.flags = kFlagExtended;
  }

  const char* d = hash + 1;
  int len = 0;
  if (d < end && *d == '#') {  // CAN FD
    if (frame.error()) return "error frame written as CAN FD";
    ++d;
    if (d == end) return "CAN FD frame without flags nibble";
    const int nibble = HexValue(*d);
    if (nibble < 0) return "bad CAN FD flags nibble";
    if ((nibble & ~0x7) != 0) return "unknown CAN FD flags";  // BRS=1, ESI=2, FDF=4
    frame.flags |= kFlagFd;
    if (nibble & 0x1) frame.flags |= kFlagFdBrs;
    if (nibble & 0x2) frame.flags |= kFlagFdEsi;
    if (const char* why = ParseHexBytes(d + 1, end, kMaxPayload, frame.data.data(), len)) return why;
    if (!IsValidFdLength(len)) return "CAN FD length not expressible by a DLC";
  } else if (d < end && *d == 'R') {  // remote frame, optional DLC digit
    if (frame.error()) return "error frame written as remote frame";
    frame.flags |= kFlagRemote;
    ++d;
    if (d < end) {
      if (end - d != 1 || *d < '0' || *d > '8') return "bad remote frame DLC";
      len = *d - '0';
    }
  } else {  // classic data, optional "_X" raw DLC 9..F for 8-byte frames (accepted, dropped)
    const char* data_end = static_cast<const char*>(std::memchr(d, '_', end - d));
    if (data_end != nullptr) {
      if (end - data_end != 2 || HexValue(data_end[1]) < 9) return "bad raw DLC after '_'";
    } else {
      data_end = end;
    }
    if (const char* why = ParseHexBytes(d, data_end, 8, frame.data.data(), len)) return why;
    if (data_end != end && len != 8) return "raw DLC after '_' needs 8 data bytes";
  }
  frame.len = static_cast<uint8_t>(len);
  return nullptr;
}

}  // namespace

bool IsBlankOrComment(std::string_view line) noexcept {
  for (char c : line) {
    if (IsBlank(c) || c == '\r') continue;
    return c == '#';
  }
  return true;
}

const char* ParseLine(std::string_view line, CanFrame& frame, std::string_view& bus_name) noexcept {
  const char* p = line.data();
  const char* end = p + line.size();
  while (end > p && (IsBlank(end[-1]) || end[-1] == '\r' || end[-1] == '\n')) --end;
  if (p == end) return "empty line";
  frame.flags = 0;
  frame.len = 0;
  frame.data.fill(0);

  // (seconds.fraction)
  if (*p != '(') return "missing '(' before timestamp";
  ++p;
  int64_t seconds = 0;
  const char* digits = p;
  while (p < end && IsDigit(*p)) {
    if (seconds > kMaxSeconds / 10) return "timestamp out of range";
    seconds = seconds * 10 + (*p++ - '0');
  }
  if (p == digits) return "missing timestamp seconds";
  if (p == end || *p != '.') return "timestamp without '.' fraction";
  ++p;
  int64_t fraction = 0;
  int fraction_digits = 0;
  while (p < end && IsDigit(*p)) {
    if (++fraction_digits > 9) return "timestamp fraction longer than 9 digits";
    fraction = fraction * 10 + (*p++ - '0');
  }
  if (fraction_digits == 0) return "missing timestamp fraction";
  if (p == end || *p != ')') return "missing ')' after timestamp";
  ++p;
  for (int i = fraction_digits; i < 9; ++i) fraction *= 10;
  frame.timestamp_ns = seconds * kNsPerSecond + fraction;

  // interface name
  if (p == end || !IsBlank(*p)) return "missing blank after timestamp";
  while (p < end && IsBlank(*p)) ++p;
  const char* name = p;
  while (p < end && !IsBlank(*p)) ++p;
  if (p == name) return "missing interface name";
  if (static_cast<size_t>(p - name) > kMaxBusNameChars) return "interface name longer than 15 characters";
  bus_name = std::string_view(name, static_cast<size_t>(p - name));

  // frame token
  while (p < end && IsBlank(*p)) ++p;
  const char* token = p;
  while (p < end && !IsBlank(*p)) ++p;
  if (p == token) return "missing frame after interface name";
  const char* token_end = p;

  // optional direction flag (asc2log, candump -x style): a single R or T
  while (p < end && IsBlank(*p)) ++p;
  if (p < end) {
    if (end - p != 1 || (*p != 'R' && *p != 'T')) return "unexpected text after frame";
  }
  return ParseFrameToken(token, token_end, frame);
}

}  // namespace detail

std::string ParseCandumpLine(std::string_view line, CanFrame& frame, std::string_view& bus_name) noexcept {
  frame.bus = 0;
  const char* why = detail::ParseLine(line, frame, bus_name);
  if (why == nullptr) return {};
  try {
    return why;
  } catch (...) {
    return {};  // unreachable in practice: allocation of a short message failed
  }
}

std::string FormatCandumpLine(const CanFrame& frame, std::string_view bus_name) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out.reserve(48 + 2 * frame.len + bus_name.size());
  char buf[48];
  const int64_t ns = frame.timestamp_ns;
  const char* sign = ns < 0 ? "-" : "";
  const uint64_t abs_ns = ns < 0 ? 0 - static_cast<uint64_t>(ns) : static_cast<uint64_t>(ns);
  const auto seconds = static_cast<unsigned long long>(abs_ns / detail::kNsPerSecond);
  const auto sub = static_cast<unsigned long long>(abs_ns % detail::kNsPerSecond);
  if (sub % 1000 == 0) {
    std::snprintf(buf, sizeof buf, "(%s%llu.%06llu) ", sign, seconds, sub / 1000);
  } else {
    std::snprintf(buf, sizeof buf, "(%s%llu.%09llu) ", sign, seconds, sub);
  }
  out += buf;
  out += bus_name;
  out += ' ';
  if (frame.error()) {
    std::snprintf(buf, sizeof buf, "%08X", (frame.id & kExtendedIdMask) | detail::kCanErrFlag);
  } else if (frame.extended()) {
    std::snprintf(buf, sizeof buf, "%08X", frame.id & kExtendedIdMask);
  } else {
    std::snprintf(buf, sizeof buf, "%03X", frame.id & kStandardIdMask);
  }
  out += buf;
  out += '#';
  if (frame.fd()) {
    out += '#';
    out += kHex[((frame.flags & kFlagFdBrs) ? 1 : 0) | ((frame.flags & kFlagFdEsi) ? 2 : 0)];
  } else if (frame.remote()) {
    out += 'R';
    if (frame.len > 0 && frame.len <= 8) out += static_cast<char>('0' + frame.len);
    return out;
  }
  const int len = frame.len > kMaxPayload ? kMaxPayload : frame.len;
  for (int i = 0; i < len; ++i) {
    out += kHex[frame.data[i] >> 4];
    out += kHex[frame.data[i] & 0xF];
  }
  return out;
}

}  // namespace ndsid::can
