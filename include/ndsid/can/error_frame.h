// Human-readable description of a SocketCAN error frame (kFlagError): the CAN_ERR_* class bits
// in CanFrame::id and the detail bytes in data[0..7], as linux/can/error.h defines them.
#pragma once

#include <string>

#include "ndsid/can/can_frame.h"

namespace ndsid::can {

// E.g. "bus-off; controller: rx-error-passive; tx/rx error counters 128/0".
// Returns "not an error frame" for frames without kFlagError.
std::string DescribeErrorFrame(const CanFrame& frame);

// True when the error frame reports a state the bus cannot recover from by itself
// (bus-off, or a controller restart is needed).
bool IsBusOffError(const CanFrame& frame) noexcept;

}  // namespace ndsid::can
