// The daemon's log input: the log files of config.source.logs (any format can::OpenFrameLog
// reads), one after another, as one FrameSource (kEnd only after the last). A file that cannot be
// opened is logged and skipped; both that and a file not read to its end count as input errors
// (the daemon then exits 74).
// Thread: the reading thread (the only reader of the frame source).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ndsid/can/frame_log.h"
#include "ndsid/can/frame_source.h"

namespace ndsid::service {

class LogSequence final : public can::FrameSource {
 public:
  explicit LogSequence(std::vector<std::string> paths);
  can::ReadResult Read(std::span<can::CanFrame> out, int timeout_ms) noexcept override;
  const can::SourceCounters& counters() const noexcept override;
  const std::vector<std::string>& bus_names() const noexcept override;
  std::string Describe() const override;
  // Logs that could not be opened or were not read to their end (read error, truncated gzip).
  size_t input_errors() const noexcept { return input_errors_; }

 private:
  void CloseCurrent() noexcept;

  std::vector<std::string> paths_;
  size_t next_ = 0;
  std::unique_ptr<can::FrameLog> current_;
  can::SourceCounters finished_;       // of the files already read
  mutable can::SourceCounters total_;  // finished_ + current
  std::vector<std::string> no_buses_;
  size_t input_errors_ = 0;
};

}  // namespace ndsid::service
