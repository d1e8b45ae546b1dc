#include "socketcan_records.h"

#include <linux/can.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "candump_line.h"

namespace ndsid::can::detail {

static_assert(sizeof(can_frame) == CAN_MTU && CAN_MTU == 16);
static_assert(sizeof(canfd_frame) == CANFD_MTU && CANFD_MTU == 72);
static_assert(CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(uint32_t)) <= kControlBytes);

RecordVerdict DecodeRecord(const uint8_t* record, size_t size, CanFrame& frame) noexcept {
  if (size != CAN_MTU && size != CANFD_MTU) return RecordVerdict::kMalformed;
  canfd_frame raw;  // can_frame is a layout prefix of canfd_frame
  std::memcpy(&raw, record, size);
  const bool fd = size == CANFD_MTU;
  const int len = raw.len;
  if (fd ? !IsValidFdLength(len) : len > CAN_MAX_DLEN) return RecordVerdict::kMalformed;

  frame.flags = 0;
  if (raw.can_id & CAN_ERR_FLAG) {
    frame.id = raw.can_id & CAN_ERR_MASK;
    frame.flags = kFlagError;
  } else if (raw.can_id & CAN_EFF_FLAG) {
    frame.id = raw.can_id & CAN_EFF_MASK;
    frame.flags = kFlagExtended;
  } else {
    frame.id = raw.can_id & CAN_SFF_MASK;
  }
  if (fd) {
    if (frame.error() || (raw.can_id & CAN_RTR_FLAG)) return RecordVerdict::kMalformed;
    frame.flags |= kFlagFd;
    if (raw.flags & CANFD_BRS) frame.flags |= kFlagFdBrs;
    if (raw.flags & CANFD_ESI) frame.flags |= kFlagFdEsi;
  } else if ((raw.can_id & CAN_RTR_FLAG) && !frame.error()) {
    frame.flags |= kFlagRemote;
  }
  frame.len = static_cast<uint8_t>(len);
  frame.data.fill(0);
  if (!frame.remote()) std::memcpy(frame.data.data(), raw.data, static_cast<size_t>(len));
  return frame.error() ? RecordVerdict::kError : RecordVerdict::kFrame;
}

Control ReadControl(const msghdr& message) noexcept {
  Control control;
  if (message.msg_control == nullptr) return control;
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr;
       c = CMSG_NXTHDR(const_cast<msghdr*>(&message), c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SO_TIMESTAMPNS && c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
      timespec ts;
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      control.has_timestamp = true;
      control.timestamp_ns = static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
    } else if (c->cmsg_type == SO_RXQ_OVFL && c->cmsg_len >= CMSG_LEN(sizeof(uint32_t))) {
      std::memcpy(&control.drop_count, CMSG_DATA(c), sizeof control.drop_count);
      control.has_drop_count = true;
    }
  }
  return control;
}

bool IsDisconnectErrno(int error) noexcept {
  switch (error) {
    case ENODEV:
    case ENETDOWN:
    case ENXIO:
    case EBADF:
    case ENOTCONN:
    case ECONNRESET:
    case EPIPE:
      return true;
    default:
      return false;
  }
}

}  // namespace ndsid::can::detail
