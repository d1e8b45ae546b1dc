// ASC lines (Vector's "CAN ASCII log", as CANoe/CANalyzer and python-can write it):
//   date Mon Nov 23 08:00:00.000 am 2026          header: start date (read as UTC)
//   base hex  timestamps absolute                  ids/data in hex|dec; times since start|delta
//   Begin Triggerblock Mon Nov 23 08:00:00.000 2026
//      0.012345 1  123             Rx   d 8 01 02 03 04 05 06 07 08  Length = ...
//      0.012345 1  1ABCDEF0x       Tx   r 8                             remote frame
//      0.012345 1  ErrorFrame
//      0.012345 CANFD   1 Rx 123  Name  1 0 d 64 00 01 ... (then timing fields)
//   End TriggerBlock
// The channel number N becomes bus "can<N-1>" (python-can's convention), so a log converted
// from `candump -l` keeps its interface names can0, can1, ...
#include "asc_reader.h"

#include <cstring>

#include "line_input.h"
#include "ndsid/common/error.h"
#include "text_time.h"

namespace ndsid::can::detail {
namespace {

constexpr size_t kMaxTokens = 80;

struct Tokens {
  std::string_view t[kMaxTokens];
  size_t n = 0;
};

void Split(std::string_view line, Tokens& out) noexcept {
  out.n = 0;
  size_t i = 0;
  while (i < line.size() && out.n < kMaxTokens) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.t[out.n++] = line.substr(start, i - start);
  }
}

bool IEquals(std::string_view a, std::string_view b) noexcept {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

bool IStartsWith(std::string_view s, std::string_view prefix) noexcept {
  return s.size() >= prefix.size() && IEquals(s.substr(0, prefix.size()), prefix);
}

// Unsigned number in base 16 or 10; false on any other character or overflow of 32 bits.
bool ParseNumber(std::string_view s, int base, uint32_t& out) noexcept {
  if (s.empty() || s.size() > 10) return false;
  uint64_t v = 0;
  for (const char c : s) {
    int d = -1;
    if (c >= '0' && c <= '9') d = c - '0';
    else if (base == 16 && c >= 'a' && c <= 'f') d = c - 'a' + 10;
    else if (base == 16 && c >= 'A' && c <= 'F') d = c - 'A' + 10;
    if (d < 0) return false;
    v = v * static_cast<uint64_t>(base) + static_cast<uint64_t>(d);
    if (v > 0xFFFFFFFFu) return false;
  }
  out = static_cast<uint32_t>(v);
  return true;
}

// The text from token i to the end of the line.
std::string_view Rest(const Tokens& tok, size_t i) noexcept {
  const std::string_view& last = tok.t[tok.n - 1];
  return std::string_view(tok.t[i].data(), static_cast<size_t>(last.data() + last.size() - tok.t[i].data()));
}

bool IsDirection(std::string_view s) noexcept { return IEquals(s, "Rx") || IEquals(s, "Tx"); }

class AscReader final : public FrameLogBase {
 public:
  explicit AscReader(const std::string& path) : FrameLogBase(path, LogFormat::kAsc, false) {
    if (!input_.Open(path)) throw Error("ASC log " + path + ": cannot open: " + input_.error());
  }
  std::string Describe() const override {
    return FrameLogBase::Describe() + (input_.compressed() ? " (gzip)" : "");
  }

 private:
  bool Next(CanFrame& frame) noexcept override;
  // Header or block line (not starting with a time); false when it is none of the known ones.
  bool HeaderLine(const Tokens& tok) noexcept;
  // Parses an event line; nullptr = a frame was produced, kSkip = not a frame, else the reason.
  const char* EventLine(const Tokens& tok, CanFrame& frame) noexcept;
  const char* ClassicFrame(const Tokens& tok, CanFrame& frame) noexcept;
  const char* FdFrame(const Tokens& tok, CanFrame& frame) noexcept;
  bool Id(std::string_view token, CanFrame& frame) const noexcept;
  const char* Bytes(const Tokens& tok, size_t first, int count, CanFrame& frame) const noexcept;

  static constexpr const char* kSkip = "";
  uint64_t RawOffset() const noexcept override { return input_.raw_offset(); }

  LineInput input_;
  Tokens tok_;
  int base_ = 16;
  bool relative_ = false;  // "timestamps relative": each time is a delta to the previous event
  int64_t start_ns_ = 0;   // the start date of the current trigger block (0 when there is none)
  int64_t last_ns_ = 0;    // previous event time, for relative timestamps
};

bool AscReader::HeaderLine(const Tokens& tok) noexcept {
  const std::string_view first = tok.t[0];
  if (IStartsWith(first, "//")) return true;
  if (IEquals(first, "date")) {  // "date <weekday> <date>"; the weekday is informational
    if (tok.n >= 3) {
      if (const auto ns = ParseAscDateNs(Rest(tok, 2))) start_ns_ = *ns;
    }
    return true;
  }
  if (IEquals(first, "base") && tok.n >= 2) {
    base_ = IEquals(tok.t[1], "dec") ? 10 : 16;
    if (tok.n >= 4 && IEquals(tok.t[2], "timestamps")) relative_ = IEquals(tok.t[3], "relative");
    return IEquals(tok.t[1], "dec") || IEquals(tok.t[1], "hex");
  }
  if (IEquals(first, "internal") || (IEquals(first, "no") && tok.n >= 2 && IEquals(tok.t[1], "internal"))) return true;
  if (IEquals(first, "Begin") && tok.n >= 2 && IEquals(tok.t[1], "Triggerblock")) {
    if (tok.n >= 4) {
      if (const auto ns = ParseAscDateNs(Rest(tok, 3))) start_ns_ = *ns;
    }
    last_ns_ = 0;
    return true;
  }
  if (IEquals(first, "End") && tok.n >= 2 && IEquals(tok.t[1], "Triggerblock")) return true;
  return false;
}

bool AscReader::Id(std::string_view token, CanFrame& frame) const noexcept {
  bool extended = false;
  if (!token.empty() && (token.back() == 'x' || token.back() == 'X')) {
    extended = true;
    token.remove_suffix(1);
  }
  uint32_t id = 0;
  if (!ParseNumber(token, base_, id)) return false;
  if (id > (extended ? kExtendedIdMask : kStandardIdMask)) return false;
  frame.id = id;
  if (extended) frame.flags |= kFlagExtended;
  return true;
}

const char* AscReader::Bytes(const Tokens& tok, size_t first, int count, CanFrame& frame) const noexcept {
  if (first + static_cast<size_t>(count) > tok.n) return "fewer data bytes than the length says";
  for (int i = 0; i < count; ++i) {
    uint32_t v = 0;
    if (!ParseNumber(tok.t[first + static_cast<size_t>(i)], base_, v) || v > 0xFF) return "bad data byte";
    frame.data[static_cast<size_t>(i)] = static_cast<uint8_t>(v);
  }
  frame.len = static_cast<uint8_t>(count);
  return nullptr;
}

// <time> <channel> <id>[x] <Rx|Tx> d <dlc> <bytes...> | r [dlc]
const char* AscReader::ClassicFrame(const Tokens& tok, CanFrame& frame) noexcept {
  if (IEquals(tok.t[2], "ErrorFrame")) {
    frame.flags = kFlagError;
    frame.id = kVectorErrorClass;
    return nullptr;
  }
  if (tok.n < 5 || !IsDirection(tok.t[3])) return kSkip;  // Statistic:, status and other events
  if (!Id(tok.t[2], frame)) return "bad identifier";
  uint32_t dlc = 0;
  if (IEquals(tok.t[4], "r")) {
    frame.flags |= kFlagRemote;
    if (tok.n >= 6 && ParseNumber(tok.t[5], 16, dlc) && dlc <= 8) frame.len = static_cast<uint8_t>(dlc);
    return nullptr;
  }
  if (!IEquals(tok.t[4], "d")) return "expected 'd' or 'r' after the direction";
  // The DLC in the file's base (python-can's reading; hex when that fails). A classic frame
  // carries at most 8 bytes: a larger DLC, also one above 15 (python-can writes "40" for a
  // classic message given 64 bytes), means the first 8 bytes, as python-can reads it.
  if (tok.n < 6 || !(ParseNumber(tok.t[5], base_, dlc) || ParseNumber(tok.t[5], 16, dlc))) return "bad DLC";
  return Bytes(tok, 6, dlc > 8 ? 8 : static_cast<int>(dlc), frame);
}

// <time> CANFD <channel> <Rx|Tx> <id>[x] [name] <brs> <esi> <dlc hex> <data length> <bytes...>
const char* AscReader::FdFrame(const Tokens& tok, CanFrame& frame) noexcept {
  if (tok.n >= 4 && IEquals(tok.t[3], "ErrorFrame")) {
    frame.flags = kFlagError;
    frame.id = kVectorErrorClass;
    return nullptr;
  }
  if (tok.n >= 5 && IEquals(tok.t[4], "ErrorFrame")) {
    frame.flags = kFlagError;
    frame.id = kVectorErrorClass;
    return nullptr;
  }
  if (tok.n >= 5 && IsDirection(tok.t[4])) return "CANFD line with the id before the direction (a layout not read)";
  if (tok.n < 9 || !IsDirection(tok.t[3])) return "CANFD line too short";
  if (!Id(tok.t[4], frame)) return "bad identifier";
  size_t k = 5;
  if (!(tok.t[k] == "0" || tok.t[k] == "1")) ++k;  // a symbolic message name
  if (k + 4 > tok.n) return "CANFD line too short";
  const bool brs = tok.t[k] == "1", esi = tok.t[k + 1] == "1";
  uint32_t dlc = 0, length = 0;
  if (!ParseNumber(tok.t[k + 2], 16, dlc) || dlc > 15) return "bad DLC";
  if (!ParseNumber(tok.t[k + 3], 10, length) || length > 64) return "bad data length";
  if (length == 0 && dlc > 0) {  // a remote frame
    frame.flags |= kFlagRemote;
    frame.len = static_cast<uint8_t>(dlc <= 8 ? dlc : 8);
    return nullptr;
  }
  if (static_cast<int>(length) != FdDlcToLength(static_cast<int>(dlc)) && !(dlc > 8 && length == 8)) {
    return "data length does not match the DLC";
  }
  frame.flags |= kFlagFd | (brs ? kFlagFdBrs : 0) | (esi ? kFlagFdEsi : 0);
  return Bytes(tok, k + 4, static_cast<int>(length), frame);
}

const char* AscReader::EventLine(const Tokens& tok, CanFrame& frame) noexcept {
  const auto t = ParseSecondsNs(tok.t[0]);
  if (!t) return "bad timestamp";
  if (tok.n < 3) return kSkip;  // e.g. a bare time
  const char* why = kSkip;
  if (IEquals(tok.t[1], "CANFD")) {
    uint32_t channel = 0;
    if (!ParseNumber(tok.t[2], 10, channel)) return "bad channel";
    why = FdFrame(tok, frame);
    if (why == nullptr) {
      const int bus = BusForChannel(channel == 0 ? 0 : channel - 1);
      if (bus < 0) return "more than 256 channels in one file";
      frame.bus = static_cast<uint16_t>(bus);
    }
  } else {
    uint32_t channel = 0;
    if (!ParseNumber(tok.t[1], 10, channel)) return kSkip;  // "Start of measurement", "SV:", ...
    why = ClassicFrame(tok, frame);
    if (why == nullptr) {
      const int bus = BusForChannel(channel == 0 ? 0 : channel - 1);
      if (bus < 0) return "more than 256 channels in one file";
      frame.bus = static_cast<uint16_t>(bus);
    }
  }
  int64_t event_ns = *t;
  if ((relative_ && !AddTime(last_ns_, *t, event_ns)) || !AddTime(start_ns_, event_ns, frame.timestamp_ns)) {
    return "time out of range";
  }
  if (why == nullptr || why == kSkip) last_ns_ = event_ns;
  return why;
}

bool AscReader::Next(CanFrame& frame) noexcept {
  std::string_view line;
  while (input_.Next(line)) {
    const uint64_t n = input_.line_number();
    if (input_.too_long()) {
      Reject(n, "line longer than 4096 bytes");
      continue;
    }
    Split(line, tok_);
    if (tok_.n == 0) continue;
    const char c = tok_.t[0][0];
    if (c < '0' || c > '9') {
      if (!HeaderLine(tok_)) Reject(n, "not an ASC header or event line");
      continue;
    }
    frame = CanFrame{};
    const char* why = EventLine(tok_, frame);
    if (why == nullptr) return true;
    if (why == kSkip) {
      Skip();
    } else {
      Reject(n, why);
    }
  }
  if (!input_.error().empty()) Stop(input_.line_number(), input_.error());
  return false;
}

}  // namespace

std::unique_ptr<FrameLog> OpenAscLog(const std::string& path) { return std::make_unique<AscReader>(path); }

}  // namespace ndsid::can::detail
