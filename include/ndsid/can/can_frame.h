// One CAN or CAN FD frame as the pipeline carries it, independent of where it came from
// (a candump log, a SocketCAN socket, the simulator).
#pragma once

#include <array>
#include <cstdint>
#include <span>

namespace ndsid::can {

// Flag bits of CanFrame::flags.
inline constexpr uint8_t kFlagExtended = 1u << 0;  // 29-bit identifier
inline constexpr uint8_t kFlagRemote = 1u << 1;    // RTR frame (no payload)
inline constexpr uint8_t kFlagError = 1u << 2;     // error frame; id holds CAN_ERR_* class bits
inline constexpr uint8_t kFlagFd = 1u << 3;        // CAN FD frame (len up to 64)
inline constexpr uint8_t kFlagFdBrs = 1u << 4;     // CAN FD bit-rate switch
inline constexpr uint8_t kFlagFdEsi = 1u << 5;     // CAN FD error-state indicator

inline constexpr uint32_t kStandardIdMask = 0x7FFu;
inline constexpr uint32_t kExtendedIdMask = 0x1FFFFFFFu;
inline constexpr int kMaxPayload = 64;

struct CanFrame {
  int64_t timestamp_ns = 0;  // kernel-style receive time (ns since the epoch, or since boot in logs)
  uint32_t id = 0;           // 11- or 29-bit identifier, no flag bits
  uint8_t flags = 0;         // kFlag* bits
  uint8_t len = 0;           // payload length in bytes, 0..64 (DLC 0..8 for classic CAN)
  uint16_t bus = 0;          // index of the interface ("can0", "can1", ...) in the source's bus table
  std::array<uint8_t, kMaxPayload> data{};

  bool extended() const { return (flags & kFlagExtended) != 0; }
  bool remote() const { return (flags & kFlagRemote) != 0; }
  bool error() const { return (flags & kFlagError) != 0; }
  bool fd() const { return (flags & kFlagFd) != 0; }
  std::span<const uint8_t> payload() const { return {data.data(), len}; }
};

}  // namespace ndsid::can
