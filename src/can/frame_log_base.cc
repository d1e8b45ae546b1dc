#include "frame_log_base.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>

#include "can_logger.h"
#include "ndsid/common/error.h"

namespace ndsid::can::detail {

FrameLogBase::FrameLogBase(std::string path, LogFormat format, bool binary)
    : path_(std::move(path)), format_(format), binary_(binary), log_(CanLogger()) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path_, ec);
  file_size_ = ec ? 0 : static_cast<uint64_t>(size);
}

double FrameLogBase::fraction_read() const noexcept {
  if (file_size_ == 0 || RawOffset() == kUnknownOffset) return -1.0;
  return std::min(1.0, static_cast<double>(RawOffset()) / static_cast<double>(file_size_));
}

FrameLogBase::~FrameLogBase() = default;

ReadResult FrameLogBase::Read(std::span<CanFrame> out, int /*timeout_ms*/) noexcept {
  if (out.empty()) return {0, SourceState::kOk};
  size_t count = 0;
  while (count < out.size() && !stopped_) {
    CanFrame& frame = out[count];
    frame = CanFrame{};
    if (!Next(frame)) break;
    if (frame.timestamp_ns < last_timestamp_ns_) ++counters_.time_backwards;
    last_timestamp_ns_ = frame.timestamp_ns;
    if (frame.error()) ++counters_.error_frames;
    ++counters_.frames;
    ++count;
  }
  return {count, count > 0 ? SourceState::kOk : SourceState::kEnd};
}

std::string FrameLogBase::Locate(const MalformedRecord& record) const {
  if (!binary_) return FormatLocation(path_, static_cast<int>(record.position), 0, record.reason);
  return path_ + ": byte " + std::to_string(record.position) + ": " + record.reason;
}

std::string FrameLogBase::Describe() const {
  return std::string(LogFormatName(format_)) + " log " + path_;
}

void FrameLogBase::Reject(uint64_t position, const char* reason) noexcept {
  ++counters_.malformed;
  if (first_malformed_.size() >= kKeptMalformed) return;
  try {
    first_malformed_.push_back({position, reason});
    log_->warn("{}", Locate(first_malformed_.back()));
    if (first_malformed_.size() == kKeptMalformed) {
      log_->warn("{}: further malformed records are counted, not logged", path_);
    }
  } catch (...) {
  }
}

void FrameLogBase::Stop(uint64_t position, const std::string& why) noexcept {
  if (stopped_) return;
  stopped_ = true;
  try {
    io_error_ = why;
    log_->error("{}", Locate({position, "reading stopped: " + why}));
  } catch (...) {
  }
}

int FrameLogBase::BusForChannel(uint32_t channel) noexcept {
  if (channel > kMaxChannel) return -1;
  int& index = bus_of_channel_[channel];
  if (index >= 0) return index;
  try {
    bus_names_.push_back("can" + std::to_string(channel));
  } catch (...) {
    return -1;
  }
  return index = static_cast<int>(bus_names_.size() - 1);
}

}  // namespace ndsid::can::detail
