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
    if (!Next(frame)) {
      CheckMostlyMalformed();
      break;
    }
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
  if (!keeps_malformed()) {
    ++counters_.malformed;
    return;
  }
  try {
    Reject(position, std::string(reason));
  } catch (...) {
    ++counters_.malformed;
  }
}

void FrameLogBase::Reject(uint64_t position, std::string reason) noexcept {
  ++counters_.malformed;
  if (first_malformed_.size() >= kKeptMalformed) return;
  try {
    first_malformed_.push_back({position, std::move(reason)});
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

void FrameLogBase::CheckMostlyMalformed() noexcept {
  if (stopped_ || counters_.malformed == 0 || counters_.malformed <= counters_.frames) return;
  if (first_malformed_.empty()) {
    Stop(0, "most CAN records are malformed");
    return;
  }
  try {
    const MalformedRecord& first = first_malformed_.front();
    Stop(first.position, std::to_string(counters_.malformed) + " of " +
                             std::to_string(counters_.malformed + counters_.frames) +
                             " CAN records are malformed, the first: " + Locate(first));
  } catch (...) {
    Stop(0, "most CAN records are malformed");
  }
}

int FrameLogBase::BusForChannel(uint64_t channel) noexcept {
  if (last_channel_.first == channel) return last_channel_.second;
  for (const auto& entry : bus_of_channel_) {
    if (entry.first == channel) {
      last_channel_ = entry;
      return entry.second;
    }
  }
  if (bus_of_channel_.size() >= kMaxBuses) return -1;
  try {
    bus_names_.push_back("can" + std::to_string(channel));
    bus_of_channel_.emplace_back(channel, static_cast<int>(bus_names_.size() - 1));
  } catch (...) {
    return -1;
  }
  last_channel_ = bus_of_channel_.back();
  return last_channel_.second;
}

}  // namespace ndsid::can::detail
