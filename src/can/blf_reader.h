// Vector BLF (binary logging format) reader: zlib or uncompressed LOG_CONTAINER objects of any
// size, streamed through inflate in pieces; CAN_MESSAGE, CAN_MESSAGE2, CAN_FD_MESSAGE,
// CAN_FD_MESSAGE_64, CAN_ERROR, CAN_ERROR_EXT and CAN_FD_ERROR_64 (blf_objects.h); other
// objects are skipped and counted.
#pragma once

#include <memory>
#include <string>

#include "frame_log_base.h"

namespace ndsid::can::detail {

// Throws Error naming the path when the file cannot be opened or has no BLF file header.
std::unique_ptr<FrameLog> OpenBlfLog(const std::string& path);

}  // namespace ndsid::can::detail
