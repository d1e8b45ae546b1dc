// BLF object layouts (little endian; after Toby Lorenz' vector_blf and python-can's blf.py):
//   header v1  base header, u32 flags, u16 client index, u16 object version, u64 time      (32 bytes)
//   header v2  base header, u32 flags, u8 time status, u8, u16 object version, u64 time,
//              u64 original time                                                           (40 bytes)
//              flags 1 = TIME_TEN_MICS (time in 10 us), 2 = TIME_ONE_NANS (time in ns)
// Bodies, after the header (its size as the base header says):
//   CAN_MESSAGE (1), CAN_MESSAGE2 (86)  u16 channel, u8 flags (0x80 remote), u8 dlc,
//                                       u32 id (bit 31 extended), u8 data[8], ...
//   CAN_ERROR (2), CAN_ERROR_EXT (73)   u16 channel, u16 length, ...
//   CAN_FD_MESSAGE (100)                u16 channel, u8 flags (0x80 remote), u8 dlc, u32 id,
//                                       u32 frame length, u8 bit count, u8 FD flags (EDL 1,
//                                       BRS 2, ESI 4), u8 valid bytes, 5 reserved, u8 data[64]
//   CAN_FD_MESSAGE_64 (101)             u8 channel, u8 dlc, u8 valid bytes, u8 tx count,
//                                       u32 id, u32 frame length, u32 flags (remote 0x10,
//                                       EDL 0x1000, BRS 0x2000, ESI 0x4000), 4 x u32 timing,
//                                       u16 bit count, u8 dir, u8 ext data offset, u32 crc,
//                                       then the data                                 (40 + data)
//   CAN_FD_ERROR_64 (104)               u8 channel, ...
//   GLOBAL_MARKER (96)                  3 x u32 type and colours, u8, 3 reserved, 3 x u32 string
//                                       lengths, 12 reserved, then the strings (beyond the size
//                                       field when Vector's converter writes it)
#include "blf_objects.h"

#include <algorithm>
#include <cstring>

#include "frame_log_base.h"

namespace ndsid::can::detail {
namespace {

constexpr uint32_t kExtendedIdBit = 0x80000000u;
constexpr uint32_t kHeaderV1Bytes = 32, kHeaderV2Bytes = 40;
constexpr uint32_t kTimeTenMics = 1;
constexpr uint32_t kGlobalMarker = 96, kGlobalMarkerFixed = 40;
constexpr int64_t kTenMicsNs = 10'000;

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t U32(const uint8_t* p) { return U16(p) | static_cast<uint32_t>(U16(p + 2)) << 16; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

BlfDecoded Malformed(const char* reason) { return {BlfVerdict::kMalformed, reason, 0}; }

// The object's time in ns since the epoch (or since the start, when the file has no start
// time); nullptr, or why the object cannot be placed in time.
const char* ObjectTime(const uint8_t* obj, int64_t start_ns, int64_t& out) noexcept {
  const uint32_t flags = U32(obj + 16);
  const uint64_t stamp = U64(obj + 24);
  const uint64_t limit = flags == kTimeTenMics ? static_cast<uint64_t>(INT64_MAX / kTenMicsNs) : static_cast<uint64_t>(INT64_MAX);
  if (stamp > limit) return "object time stamp out of range (cannot be placed in time)";
  const int64_t offset_ns = static_cast<int64_t>(stamp) * (flags == kTimeTenMics ? kTenMicsNs : 1);
  if (!AddTime(start_ns, offset_ns, out)) return "object time out of range (cannot be placed in time)";
  return nullptr;
}

// Sets id and the extended flag; a standard id above 0x7FF is no CAN frame.
const char* SetId(uint32_t raw_id, CanFrame& frame) noexcept {
  frame.id = raw_id & kExtendedIdMask;
  if (raw_id & kExtendedIdBit) {
    frame.flags |= kFlagExtended;
  } else if (frame.id > kStandardIdMask) {
    return "standard identifier above 0x7FF (without the extended bit)";
  }
  return nullptr;
}

// CAN_MESSAGE, CAN_MESSAGE2: a DLC above 8 carries 8 bytes.
const char* CanMessage(const uint8_t* body, uint32_t body_size, CanFrame& frame, uint32_t& channel) noexcept {
  if (body_size < 16) return "CAN_MESSAGE object too short";
  channel = U16(body);
  const uint8_t msg_flags = body[2];
  const uint8_t dlc = body[3];
  frame.len = dlc > 8 ? 8 : dlc;
  if (msg_flags & 0x80) frame.flags |= kFlagRemote;
  else std::memcpy(frame.data.data(), body + 8, frame.len);
  return SetId(U32(body + 4), frame);
}

// CAN_FD_MESSAGE: an FD frame when EDL is set, its length the DLC's capped by the valid bytes.
const char* CanFdMessage(const uint8_t* body, uint32_t body_size, CanFrame& frame, uint32_t& channel) noexcept {
  if (body_size < 84) return "CAN_FD_MESSAGE object too short";
  channel = U16(body);
  const uint8_t msg_flags = body[2];
  const uint8_t dlc = body[3];
  const uint8_t fd_flags = body[13];
  const uint8_t valid = body[14];
  if (fd_flags & 0x1) {
    frame.flags |= kFlagFd | ((fd_flags & 0x2) ? kFlagFdBrs : 0) | ((fd_flags & 0x4) ? kFlagFdEsi : 0);
    const int len = FdDlcToLength(dlc & 0xF);
    frame.len = static_cast<uint8_t>(valid < len ? valid : len);
  } else {
    frame.len = dlc > 8 ? 8 : dlc;
  }
  if (msg_flags & 0x80) frame.flags |= kFlagRemote;
  else std::memcpy(frame.data.data(), body + 20, frame.len);
  return SetId(U32(body + 4), frame);
}

// CAN_FD_MESSAGE_64: the data follows the 40 fixed bytes; bytes missing from a short object
// read as zero (as CANoe and python-can do). An extended-data offset past the object's end (a
// damaged or hostile file) ends the data at the object's end: nothing beyond it is read.
const char* CanFdMessage64(const uint8_t* body, uint32_t body_size, uint32_t header_size, CanFrame& frame,
                           uint32_t& channel) noexcept {
  if (body_size < 40) return "CAN_FD_MESSAGE_64 object too short";
  channel = body[0];
  const uint8_t dlc = body[1];
  const uint8_t valid = body[2];
  const uint32_t fd_flags = U32(body + 12);
  const uint8_t ext_offset = body[37];
  if (fd_flags & 0x1000) {
    frame.flags |= kFlagFd | ((fd_flags & 0x2000) ? kFlagFdBrs : 0) | ((fd_flags & 0x4000) ? kFlagFdEsi : 0);
    const int len = FdDlcToLength(dlc & 0xF);
    frame.len = static_cast<uint8_t>(valid < len ? valid : len);
  } else {
    frame.len = static_cast<uint8_t>(dlc > 8 ? 8 : dlc);
    if (valid < frame.len) frame.len = valid;
  }
  if (fd_flags & 0x0010) {
    frame.flags |= kFlagRemote;
  } else {
    const uint32_t end = ext_offset != 0 && ext_offset >= header_size + 40u
                             ? std::min<uint32_t>(ext_offset - header_size, body_size)
                             : body_size;
    const uint32_t present = end > 40 ? end - 40 : 0;
    std::memcpy(frame.data.data(), body + 40, present < frame.len ? present : frame.len);
  }
  return SetId(U32(body + 4), frame);
}

// CAN_ERROR, CAN_ERROR_EXT, CAN_FD_ERROR_64: an error frame of unspecified kind.
const char* ErrorObject(uint32_t type, const uint8_t* body, uint32_t body_size, CanFrame& frame,
                        uint32_t& channel) noexcept {
  if (body_size < 4) return "CAN error object too short";
  channel = type == kBlfCanFdError64 ? body[0] : U16(body);
  frame.flags = kFlagError;
  frame.id = kVectorErrorClass;
  frame.len = 8;
  return nullptr;
}

}  // namespace

uint64_t BlfObjectExtent(const uint8_t* obj, uint32_t size, size_t available) noexcept {
  if (U32(obj + 12) != kGlobalMarker) return size;
  const uint32_t header_size = U16(obj + 4);
  if (header_size < kBlfBaseHeaderBytes || size < header_size + kGlobalMarkerFixed) return size;
  if (available < header_size + kGlobalMarkerFixed) return 0;
  const uint8_t* body = obj + header_size;
  const uint64_t strings = uint64_t{U32(body + 16)} + U32(body + 20) + U32(body + 24);
  return std::max<uint64_t>(size, header_size + kGlobalMarkerFixed + strings);
}

bool IsBlfCanObject(uint32_t type) noexcept {
  return type == kBlfCanMessage || type == kBlfCanMessage2 || type == kBlfCanFdMessage || type == kBlfCanFdMessage64 ||
         type == kBlfCanErrorExt || type == kBlfCanError || type == kBlfCanFdError64;
}

BlfDecoded DecodeBlfObject(const uint8_t* obj, uint32_t size, int64_t start_ns, CanFrame& frame) noexcept {
  const uint32_t header_size = U16(obj + 4);
  const uint16_t version = U16(obj + 6);
  const uint32_t type = U32(obj + 12);
  if (!IsBlfCanObject(type)) return {};
  const uint32_t needed = version == 1 ? kHeaderV1Bytes : version == 2 ? kHeaderV2Bytes : 0;
  if (needed == 0) return Malformed("object header of unknown version (neither 1 nor 2)");
  if (header_size < needed || header_size > size) return Malformed("object header size does not fit its version or object");
  if (const char* why = ObjectTime(obj, start_ns, frame.timestamp_ns)) return Malformed(why);
  const uint8_t* body = obj + header_size;
  const uint32_t body_size = size - header_size;
  BlfDecoded out{BlfVerdict::kFrame, nullptr, 0};
  switch (type) {
    case kBlfCanMessage:
    case kBlfCanMessage2: out.reason = CanMessage(body, body_size, frame, out.channel); break;
    case kBlfCanFdMessage: out.reason = CanFdMessage(body, body_size, frame, out.channel); break;
    case kBlfCanFdMessage64: out.reason = CanFdMessage64(body, body_size, header_size, frame, out.channel); break;
    default: out.reason = ErrorObject(type, body, body_size, frame, out.channel); break;
  }
  if (out.reason != nullptr) out.verdict = BlfVerdict::kMalformed;
  return out;
}

}  // namespace ndsid::can::detail
