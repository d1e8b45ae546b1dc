// Pure helpers of SocketCanSource: kernel records -> CanFrame, control messages -> timestamp
// and drop counter. Private to the CAN stage; tests include it to drive them directly.
#pragma once

#include <sys/socket.h>

#include <cstddef>
#include <cstdint>

#include "ndsid/can/can_frame.h"

namespace ndsid::can::detail {

enum class RecordVerdict {
  kFrame,      // a data or remote frame
  kError,      // an error frame (kFlagError set, id = CAN_ERR_* class bits)
  kMalformed,  // wrong record size, or a length the frame type cannot have
};

// Converts one record of `size` bytes: 16 = struct can_frame (CAN_MTU), 72 = struct
// canfd_frame (CANFD_MTU). Leaves timestamp_ns and bus untouched.
RecordVerdict DecodeRecord(const uint8_t* record, size_t size, CanFrame& frame) noexcept;

struct Control {
  bool has_timestamp = false;
  int64_t timestamp_ns = 0;   // SCM_TIMESTAMPNS (CLOCK_REALTIME, ns)
  bool has_drop_count = false;
  uint32_t drop_count = 0;    // SO_RXQ_OVFL: cumulative drops of this socket
};

// Reads the SOL_SOCKET control messages of one received message.
Control ReadControl(const msghdr& message) noexcept;

// Errors of recv/recvmmsg meaning the interface vanished or went down (close and reopen),
// as opposed to transient ones (EAGAIN, EINTR, ENOBUFS) that a later read survives.
bool IsDisconnectErrno(int error) noexcept;

// Size of the control buffer one message needs for a timestamp plus a drop counter.
inline constexpr size_t kControlBytes = 64;

}  // namespace ndsid::can::detail
