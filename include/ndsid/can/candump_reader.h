// Streaming reader for can-utils log files: `candump -l` / `candump -L` lines such as
//   (1700000000.123456) can0 123#DEADBEEF
// plain or gzip-compressed (detected by content). Never loads the whole file.
// The accepted grammar, and what counts as malformed, is in docs/can-input.md.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ndsid/can/frame_log.h"

namespace ndsid::can {

// A rejected line: its line number (position) and why.
using MalformedLine = MalformedRecord;

class CandumpReader final : public FrameLog {
 public:
  // Throws ndsid::Error naming the path when the file cannot be opened.
  explicit CandumpReader(const std::string& path);
  ~CandumpReader() override;

  ReadResult Read(std::span<CanFrame> out, int timeout_ms = 0) noexcept override;
  const SourceCounters& counters() const noexcept override;
  const std::vector<std::string>& bus_names() const noexcept override;
  std::string Describe() const override;

  LogFormat format() const noexcept override { return LogFormat::kCandump; }
  // The first few malformed lines (all of them are counted in counters().malformed).
  const std::vector<MalformedLine>& first_malformed() const noexcept override;
  // Lines read so far, including blank, comment and malformed ones.
  uint64_t lines() const noexcept;
  // Empty unless reading stopped early on an I/O or decompression error (e.g. a truncated
  // gzip file); the reader then reports kEnd.
  const std::string& io_error() const noexcept override;
  double fraction_read() const noexcept override;
  uint64_t skipped_records() const noexcept override { return 0; }
  std::string Locate(const MalformedRecord& record) const override;

  static constexpr size_t kMaxLineBytes = 512;  // longer lines are malformed (longest valid ~200)
  static constexpr size_t kMaxBuses = 256;      // distinct interface names before lines are rejected

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Parses one log line into `frame` (bus left 0) and `bus_name` (a view into `line`). Returns an
// empty string on success, else the reason the line is malformed. Blank and `#` comment lines
// are "malformed" here; the reader skips them before parsing. Exposed for tests and tools.
std::string ParseCandumpLine(std::string_view line, CanFrame& frame, std::string_view& bus_name) noexcept;

// Formats a frame as a `candump -l` line (no newline): "(sec.usec) bus ID#DATA", uppercase hex
// as candump writes it. Six fraction digits, or nine when the time is not a whole microsecond,
// so ParseCandumpLine(FormatCandumpLine(f)) == f for every valid frame.
std::string FormatCandumpLine(const CanFrame& frame, std::string_view bus_name);

}  // namespace ndsid::can
