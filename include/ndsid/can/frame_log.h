// CAN log files in every format ndsid reads, behind one factory. The format is recognised
// from the content (magic bytes, header lines), never from the file name:
//   candump -l / -L  "(1700000000.123456) can0 123#DEADBEEF" lines, plain or gzip
//   Vector ASC       text with "date ..." / "base hex|dec" / "Begin Triggerblock" header, plain or gzip
//   Vector BLF       binary, "LOGG" file header, zlib-compressed LOG_CONTAINER objects
//   ASAM MF4         "MDF     " 4.x with CAN bus-logging groups (CAN_DataFrame, ...), also
//                    unfinalised ("UnFinMF ") as stand-alone loggers write them
// Formats, recognition rules, bus naming and limits: docs/can-input.md.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ndsid/can/frame_source.h"

namespace ndsid::can {

enum class LogFormat { kCandump, kAsc, kBlf, kMf4 };

// "candump", "Vector ASC", "Vector BLF", "ASAM MF4".
const char* LogFormatName(LogFormat format);

// A rejected line or record: where (line number for text formats, byte offset for binary
// ones) and why. Readers keep the first few and count all of them in counters().malformed.
struct MalformedRecord {
  uint64_t position = 0;
  std::string reason;
};

// A log file being read. Never throws after construction: malformed records are counted and
// skipped; an I/O error or a truncated file stops reading, and io_error() says why.
class FrameLog : public FrameSource {
 public:
  virtual LogFormat format() const noexcept = 0;
  // The first kKeptMalformed rejected records (all are counted in counters().malformed).
  virtual const std::vector<MalformedRecord>& first_malformed() const noexcept = 0;
  // Empty unless reading stopped early (read error, truncated or corrupt file) or the file
  // ended with more records malformed than read; the reader then reports kEnd. Tools must not
  // treat such a file as complete.
  virtual const std::string& io_error() const noexcept = 0;
  // Records that are valid but not CAN frames (ASC statistics, BLF markers, MF4 groups that
  // are not bus logging, ...): skipped, counted here, not malformed.
  virtual uint64_t skipped_records() const noexcept = 0;
  // "file:12: reason" for text formats, "file: byte 4096: reason" for binary ones.
  virtual std::string Locate(const MalformedRecord& record) const = 0;
  // The share of the file's bytes read so far (0..1; of the compressed bytes for gzip), for
  // progress displays; -1 when unknown (MF4, whose data blocks are read interleaved).
  virtual double fraction_read() const noexcept { return -1.0; }

  static constexpr size_t kKeptMalformed = 10;
};

// What the first bytes of `path` are: a LogFormat, or throws ConfigError with one located line
// naming what the file looks like ("pcap capture", "CSV", "unknown binary", ...) and what to
// do. Throws Error when the file cannot be opened.
LogFormat DetectLogFormat(const std::string& path);

// Opens `path` with the reader for its format (DetectLogFormat's rules and errors).
std::unique_ptr<FrameLog> OpenFrameLog(const std::string& path);

}  // namespace ndsid::can
