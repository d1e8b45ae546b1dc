// Vector ASC (ASCII log) reader: CAN and CAN FD frame lines and error frames, hex or decimal
// base, absolute or relative timestamps; other events are skipped and counted. Plain or gzip.
#pragma once

#include <memory>
#include <string>

#include "frame_log_base.h"

namespace ndsid::can::detail {

// Throws Error naming the path when the file cannot be opened.
std::unique_ptr<FrameLog> OpenAscLog(const std::string& path);

}  // namespace ndsid::can::detail
