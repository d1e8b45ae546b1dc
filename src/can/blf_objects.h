// One BLF object (its header and body, complete in memory) as a CanFrame: the object header
// versions, the time units, and the layouts of the CAN object types. The container and
// stream handling is in blf_reader.cc.
#pragma once

#include <cstdint>

#include "ndsid/can/can_frame.h"

namespace ndsid::can::detail {

// BLF object types read as frames (after Toby Lorenz' vector_blf and python-can's blf.py).
inline constexpr uint32_t kBlfCanMessage = 1, kBlfCanError = 2, kBlfLogContainer = 10, kBlfCanErrorExt = 73,
                          kBlfCanMessage2 = 86, kBlfCanFdMessage = 100, kBlfCanFdMessage64 = 101,
                          kBlfCanFdError64 = 104;

// The base header every object starts with: "LOBJ", u16 header size, u16 header version,
// u32 object size (header included, padding excluded), u32 object type.
inline constexpr uint32_t kBlfBaseHeaderBytes = 16;

// The bytes the object at obj (header complete, `available` bytes from obj on) takes in the
// stream: its size, except for GLOBAL_MARKER (96), whose size as Vector's tools write it
// leaves out its three strings (vector_blf reads them by their lengths). 0 when more bytes
// are needed to tell.
uint64_t BlfObjectExtent(const uint8_t* obj, uint32_t size, size_t available) noexcept;

// True for the object types DecodeBlfObject reads as frames (CAN data, remote and error).
bool IsBlfCanObject(uint32_t type) noexcept;

// What DecodeBlfObject found.
enum class BlfVerdict {
  kFrame,     // `frame` holds a frame (bus still to be set from `channel`)
  kNotFrame,  // a valid object of another type (markers, statistics, LIN, ...): skipped
  kMalformed  // a CAN object that cannot be read; `reason` says why
};

struct BlfDecoded {
  BlfVerdict verdict = BlfVerdict::kNotFrame;
  const char* reason = nullptr;  // for kMalformed
  uint32_t channel = 0;          // the object's channel number (1-based in Vector's tools)
};

// Decodes the object obj[0, size) (size >= kBlfBaseHeaderBytes, from its "LOBJ" on). Times:
// the object's time stamp in 10 us when its header flags are 1 (TIME_TEN_MICS), else in ns,
// plus `start_ns` (the file header's start time). An object whose time does not fit in int64
// ns is malformed ("cannot be placed in time").
BlfDecoded DecodeBlfObject(const uint8_t* obj, uint32_t size, int64_t start_ns, CanFrame& frame) noexcept;

}  // namespace ndsid::can::detail
