#include <spdlog/spdlog.h>

#include "daemon_source.h"

namespace ndsid::service {

namespace {
void Add(can::SourceCounters& into, const can::SourceCounters& c) {
  into.frames += c.frames;
  into.malformed += c.malformed;
  into.error_frames += c.error_frames;
  into.dropped += c.dropped;
  into.reconnects += c.reconnects;
  into.time_backwards += c.time_backwards;
}
}  // namespace

LogSequence::LogSequence(std::vector<std::string> paths) : paths_(std::move(paths)) {}

can::ReadResult LogSequence::Read(std::span<can::CanFrame> out, int /*timeout_ms*/) noexcept {
  for (;;) {
    if (!current_) {
      if (next_ >= paths_.size()) return {0, can::SourceState::kEnd};
      const std::string& path = paths_[next_++];
      try {
        current_ = can::OpenFrameLog(path);
        spdlog::info("reading log {} ({} of {})", path, next_, paths_.size());
      } catch (const std::exception& e) {
        spdlog::error("skipping log {}: {}", path, e.what());
        ++input_errors_;
        continue;
      }
    }
    const can::ReadResult r = current_->Read(out, 0);
    if (r.count > 0 || r.state != can::SourceState::kEnd) return {r.count, can::SourceState::kOk};
    CloseCurrent();
  }
}

void LogSequence::CloseCurrent() noexcept {
  const can::SourceCounters& c = current_->counters();
  if (!current_->io_error().empty()) {
    spdlog::error("log {}: stopped early: {}", current_->Describe(), current_->io_error());
    ++input_errors_;
  }
  spdlog::info("{} done: {} frames, {} malformed records", current_->Describe(), c.frames, c.malformed);
  Add(finished_, c);
  current_.reset();
}

const can::SourceCounters& LogSequence::counters() const noexcept {
  total_ = finished_;
  if (current_) Add(total_, current_->counters());
  return total_;
}

const std::vector<std::string>& LogSequence::bus_names() const noexcept {
  return current_ ? current_->bus_names() : no_buses_;
}

std::string LogSequence::Describe() const {
  if (current_) return current_->Describe();
  return "logs (" + std::to_string(paths_.size()) + " files)";
}

}  // namespace ndsid::service
