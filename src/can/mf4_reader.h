// ASAM MF4 CAN bus-logging reader: the channel groups CAN_DataFrame, CAN_RemoteFrame and
// CAN_ErrorFrame (ASAM MDF bus logging: Timestamp master, BusChannel, ID, IDE, DLC,
// DataLength, DataBytes, Dir, EDL, BRS, ESI), sorted or unsorted, finalised or not (the
// unfinalised flags' rules of asammdf), in DT / DZ / DL / HL data blocks, DataBytes in the
// record or as VLSD (signal data, VLSD channel groups), frames of several groups merged in
// time order. Other groups are skipped.
#pragma once

#include <memory>
#include <string>

#include "frame_log_base.h"

namespace ndsid::can::detail {

// Throws Error naming the path when the file cannot be opened, is not MDF 4, or holds no CAN
// bus-logging group.
std::unique_ptr<FrameLog> OpenMf4Log(const std::string& path);

}  // namespace ndsid::can::detail
