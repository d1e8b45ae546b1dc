// Writes simulated drives as the bus carries them: a `candump -l` log (plain, or gzip when the
// name ends in .gz) of every message of the DBC at its GenMsgCycleTime, with a small fixed
// phase per message and timestamp jitter, rolling counters, XOR checksums, the multiplexed
// pages in turn and plausible bus-load values; no frames between drives (key off).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "ndsid/can/can_frame.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/sim/simulator.h"

namespace ndsid::sim {

// Encodes drives into frames (exposed for tests). `db` must outlive it.
class FrameEncoder {
 public:
  // Throws ConfigError when the DBC has no message with a cycle time.
  FrameEncoder(const dbc::Database& db, const config::SimulationConfig& config);
  ~FrameEncoder();
  FrameEncoder(const FrameEncoder&) = delete;
  FrameEncoder& operator=(const FrameEncoder&) = delete;

  // Calls `emit` for every frame of the drive in time order (timestamps in whole microseconds).
  template <typename Emit>
  void EncodeDrive(const DriveResult& drive, Emit&& emit);
  std::vector<can::CanFrame> EncodeDrive(const DriveResult& drive);

  // Messages sent, with their cycle [ms] and phase [us], for the docs and tests.
  struct MessageInfo {
    std::string name;
    double cycle_ms;
    int64_t phase_us;
  };
  std::vector<MessageInfo> messages() const;

 private:
  struct Impl;
  void EncodeDriveImpl(const DriveResult& drive, void (*emit)(void*, const can::CanFrame&), void* ctx);
  std::unique_ptr<Impl> impl_;
};

template <typename Emit>
void FrameEncoder::EncodeDrive(const DriveResult& drive, Emit&& emit) {
  EncodeDriveImpl(
      drive, [](void* ctx, const can::CanFrame& f) { (*static_cast<std::remove_reference_t<Emit>*>(ctx))(f); },
      &emit);
}

// A log file being written drive by drive.
class CandumpLogWriter {
 public:
  // gzip (zlib) when `path` ends in ".gz". Throws ndsid::Error when the file cannot be opened.
  CandumpLogWriter(const dbc::Database& db, const config::SimulationConfig& config, const std::string& path);
  ~CandumpLogWriter();
  void WriteDrive(const DriveResult& drive);
  void Close();  // flushes; throws ndsid::Error on a write error
  uint64_t frames() const { return frames_; }

 private:
  struct Sink;
  FrameEncoder encoder_;
  std::unique_ptr<Sink> sink_;
  std::string bus_;
  uint64_t frames_ = 0;
};

void WriteCandumpLog(const SimulationResult& result, const dbc::Database& db, const std::string& path);

}  // namespace ndsid::sim
