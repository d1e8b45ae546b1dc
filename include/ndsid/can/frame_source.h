// The input end of the pipeline: anything that yields CAN frames in time order.
// Implementations: CandumpReader (log files, plain or gzip), SocketCanSource (live bus).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ndsid/can/can_frame.h"

namespace ndsid::can {

// Counters every source keeps; the daemon publishes them in its status message.
struct SourceCounters {
  uint64_t frames = 0;            // frames delivered
  uint64_t malformed = 0;         // lines / records rejected as malformed
  uint64_t error_frames = 0;      // CAN error frames seen (bus-off, controller problems, ...)
  uint64_t dropped = 0;           // frames the kernel reports dropped (SocketCAN only)
  uint64_t reconnects = 0;        // times a vanished interface came back (SocketCAN only)
  uint64_t time_backwards = 0;    // frames whose timestamp was earlier than the previous one
};

enum class SourceState {
  kOk,           // frames may follow
  kTimeout,      // nothing arrived within the timeout; try again
  kEnd,          // end of a log file: no more frames ever
  kDisconnected  // the interface vanished; the source retries with back-off
};

struct ReadResult {
  size_t count = 0;  // frames written to the front of the output span
  SourceState state = SourceState::kOk;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Fills up to out.size() frames. Never throws: problems are counted and logged.
  // timeout_ms applies to live sources only (a log file never waits).
  virtual ReadResult Read(std::span<CanFrame> out, int timeout_ms) noexcept = 0;
  virtual const SourceCounters& counters() const noexcept = 0;
  // Names of the buses seen so far, indexed by CanFrame::bus.
  virtual const std::vector<std::string>& bus_names() const noexcept = 0;
  // Human-readable description for logs ("log replay/clean.log.gz", "socketcan can0").
  virtual std::string Describe() const = 0;
};

}  // namespace ndsid::can
