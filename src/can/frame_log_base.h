// Bookkeeping shared by the ASC, BLF and MF4 readers: counters, the first malformed records,
// the bus table, the stop reason. A reader derives from FrameLogBase and implements Next().
#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <string>
#include <vector>

#include "ndsid/can/frame_log.h"

namespace spdlog {
class logger;
}

namespace ndsid::can::detail {

// CAN_ERR_PROT | CAN_ERR_BUSERROR of linux/can/error.h: what a Vector / MDF error frame (a bus
// error of unspecified kind) becomes in CanFrame::id.
inline constexpr uint32_t kVectorErrorClass = 0x00000008u | 0x00000080u;

// Payload length of a CAN FD DLC code (0..15).
constexpr int FdDlcToLength(int dlc) {
  constexpr int kLengths[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};
  return dlc >= 0 && dlc < 16 ? kLengths[dlc] : -1;
}

// a + b into out; false when the sum does not fit (a corrupt time, counted by the caller).
inline bool AddTime(int64_t a, int64_t b, int64_t& out) noexcept { return !__builtin_add_overflow(a, b, &out); }

class FrameLogBase : public FrameLog {
 public:
  FrameLogBase(std::string path, LogFormat format, bool binary);
  ~FrameLogBase() override;

  ReadResult Read(std::span<CanFrame> out, int timeout_ms) noexcept final;
  // At the end of the file: when most records were malformed (more rejected than read),
  // reading stops with io_error() saying so: such a file is not a log of this format that
  // happens to be empty, and no tool may take it as complete.
  void CheckMostlyMalformed() noexcept;
  const SourceCounters& counters() const noexcept final { return counters_; }
  const std::vector<std::string>& bus_names() const noexcept final { return bus_names_; }
  LogFormat format() const noexcept final { return format_; }
  const std::vector<MalformedRecord>& first_malformed() const noexcept final { return first_malformed_; }
  const std::string& io_error() const noexcept final { return io_error_; }
  uint64_t skipped_records() const noexcept final { return skipped_; }
  std::string Locate(const MalformedRecord& record) const final;
  std::string Describe() const override;
  double fraction_read() const noexcept final;

 protected:
  // Bytes of the file consumed so far (for fraction_read), or kUnknownOffset.
  virtual uint64_t RawOffset() const noexcept = 0;
  static constexpr uint64_t kUnknownOffset = UINT64_MAX;
  // The next frame (bus set by BusForChannel), or false at the end or after Stop().
  virtual bool Next(CanFrame& frame) noexcept = 0;

  void Reject(uint64_t position, const char* reason) noexcept;
  // The same with a reason built by the caller; build it only when keeps_malformed().
  void Reject(uint64_t position, std::string reason) noexcept;
  // True while rejected records are still kept (and worth a detailed reason).
  bool keeps_malformed() const noexcept { return first_malformed_.size() < kKeptMalformed; }
  // Stops reading: the file is truncated or unreadable from here on.
  void Stop(uint64_t position, const std::string& why) noexcept;
  bool stopped() const noexcept { return stopped_; }
  void Skip() noexcept { ++skipped_; }
  // Bus index of channel number `channel` (named "can<channel>"); -1 when the file already
  // named kMaxBuses other channels.
  int BusForChannel(uint64_t channel) noexcept;

  const std::string& path() const noexcept { return path_; }

  static constexpr size_t kMaxBuses = 256;

 private:
  std::string path_;
  LogFormat format_;
  bool binary_;
  std::shared_ptr<spdlog::logger> log_;
  SourceCounters counters_;
  std::vector<std::string> bus_names_;
  std::vector<std::pair<uint64_t, int>> bus_of_channel_;  // channel -> bus index, in order of appearance
  std::pair<uint64_t, int> last_channel_{UINT64_MAX, -1};  // the last lookup (frames come in runs)
  std::vector<MalformedRecord> first_malformed_;
  std::string io_error_;
  uint64_t skipped_ = 0;
  bool stopped_ = false;
  int64_t last_timestamp_ns_ = INT64_MIN;
  uint64_t file_size_ = 0;  // at open; 0 when unknown
};

}  // namespace ndsid::can::detail
