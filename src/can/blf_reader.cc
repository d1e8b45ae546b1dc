// BLF layout (little endian; after python-can's blf.py and Toby Lorenz' vector_blf notes):
//   file header   "LOGG", u32 header size (144), ..., u64 file size @16, u64 uncompressed size,
//                 u32 object count @32, u32, SYSTEMTIME start @40 (8 x u16: year, month,
//                 weekday, day, hour, minute, second, millisecond), SYSTEMTIME stop
//   object        "LOBJ", u16 header size, u16 header version, u32 object size, u32 type,
//                 v1: u32 flags, u16 client, u16 object version, u64 time
//                 v2: u32 flags, u8 time status, u8, u16 object version, u64 time, u64 original
//                 time unit: 10 us when flags == 1 (TIME_TEN_MICS), else 1 ns
//   LOG_CONTAINER (type 10): u16 method (0 none, 2 zlib), 6 pad, u32 uncompressed size, 4 pad,
//                 then the data: a stream of objects that may continue in the next container.
// Objects are padded to 4 bytes (python-can pads object_size % 4 bytes); a reader looks for
// the next "LOBJ" within 8 bytes. Channel N is bus "can<N-1>".
#include "blf_reader.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>

#include "ndsid/common/error.h"
#include "text_time.h"

namespace ndsid::can::detail {
namespace {

constexpr uint32_t kCanMessage = 1, kLogContainer = 10, kCanErrorExt = 73, kCanMessage2 = 86,
                   kCanFdMessage = 100, kCanFdMessage64 = 101;
constexpr uint32_t kExtendedIdBit = 0x80000000u;
constexpr size_t kBaseHeader = 16;
constexpr size_t kFileHeaderMin = 72;
constexpr uint32_t kMaxObjectBytes = 64u << 20;     // larger objects are corrupt
constexpr uint32_t kMaxUncompressed = 64u << 20;

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t U32(const uint8_t* p) { return U16(p) | static_cast<uint32_t>(U16(p + 2)) << 16; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

class BlfReader final : public FrameLogBase {
 public:
  explicit BlfReader(const std::string& path) : FrameLogBase(path, LogFormat::kBlf, true) {
    file_ = gzopen(path.c_str(), "rb");
    if (file_ == nullptr) throw Error("BLF log " + path + ": cannot open: " + std::strerror(errno));
    gzbuffer(file_, 1 << 17);
    try {
      ReadFileHeader(path);
    } catch (...) {
      gzclose(file_);  // the destructor does not run when the constructor throws
      file_ = nullptr;
      throw;
    }
  }
  ~BlfReader() override {
    if (file_ != nullptr) gzclose(file_);
  }

 private:
  void ReadFileHeader(const std::string& path) {
    uint8_t header[kFileHeaderMin];
    if (ReadExact(header, sizeof header) != sizeof header || std::memcmp(header, "LOGG", 4) != 0) {
      throw Error("BLF log " + path + ": no BLF file header (truncated?)");
    }
    const uint32_t header_size = U32(header + 4);
    declared_size_ = U64(header + 16);
    declared_objects_ = U32(header + 32);
    const uint8_t* st = header + 40;
    if (const auto ns = CivilToNs(U16(st), U16(st + 2), U16(st + 6), U16(st + 8), U16(st + 10),
                                  U16(st + 12), static_cast<int64_t>(U16(st + 14)) * 1'000'000)) {
      start_ns_ = *ns;
    }
    if (header_size < kFileHeaderMin || header_size > 4096) throw Error("BLF log " + path + ": bad header size");
    std::vector<uint8_t> rest(header_size - kFileHeaderMin);
    if (ReadExact(rest.data(), rest.size()) != rest.size()) throw Error("BLF log " + path + ": truncated header");
  }
  bool Next(CanFrame& frame) noexcept override;
  uint64_t RawOffset() const noexcept override { return offset_; }
  size_t ReadExact(uint8_t* out, size_t n) noexcept;
  // Reads the next top-level object and appends its content to inner_; false at the end.
  bool LoadMore() noexcept;
  // Decodes the object at inner_[pos] (complete, size bytes); true if it is a frame.
  bool Decode(const uint8_t* obj, uint32_t size, CanFrame& frame) noexcept;

  gzFile file_ = nullptr;
  uint64_t offset_ = 0;          // bytes consumed from the file
  uint64_t declared_size_ = 0;
  uint32_t declared_objects_ = 0;
  int64_t start_ns_ = 0;
  std::vector<uint8_t> inner_;   // object stream not yet decoded: inner_[pos_, end)
  size_t pos_ = 0;
  uint64_t inner_origin_ = 0;    // file offset of the container the current inner data came from
  std::vector<uint8_t> object_;  // the current top-level object
  bool at_end_ = false;
};

size_t BlfReader::ReadExact(uint8_t* out, size_t n) noexcept {
  size_t got = 0;
  while (got < n) {
    const int r = gzread(file_, out + got, static_cast<unsigned>(n - got));
    if (r <= 0) break;
    got += static_cast<size_t>(r);
  }
  offset_ += got;
  return got;
}

bool BlfReader::LoadMore() noexcept {
  for (;;) {
    const uint64_t at = offset_;
    uint8_t head[kBaseHeader];
    const size_t got = ReadExact(head, kBaseHeader);
    int err = Z_OK;
    gzerror(file_, &err);
    if (err != Z_OK && err != Z_STREAM_END) {
      Stop(at, "read or decompression error (truncated gzip?)");
      return false;
    }
    if (got == 0) {
      if (declared_size_ > offset_) {
        Stop(offset_, "file ends at byte " + std::to_string(offset_) + " but its header says " +
                          std::to_string(declared_size_) + " (truncated)");
      }
      return false;
    }
    if (got < kBaseHeader) {
      // Zero padding at the end is fine; anything else is a cut object header.
      bool zeros = true;
      for (size_t i = 0; i < got; ++i) zeros = zeros && head[i] == 0;
      if (!zeros) Stop(at, "file ends inside an object header (truncated)");
      return false;
    }
    if (std::memcmp(head, "LOBJ", 4) != 0) {
      // Padding of 1..3 bytes the writer did not account for: find "LOBJ" in what was read.
      size_t shift = 1;
      while (shift < kBaseHeader && std::memcmp(head + shift, "LOBJ", std::min<size_t>(4, kBaseHeader - shift)) != 0) ++shift;
      bool zeros = true;
      for (size_t i = 0; i < shift; ++i) zeros = zeros && head[i] == 0;
      if (shift >= 8 || !zeros) {
        Stop(at, "no object signature \"LOBJ\" where an object must start (corrupt file)");
        return false;
      }
      std::memmove(head, head + shift, kBaseHeader - shift);
      if (ReadExact(head + kBaseHeader - shift, shift) != shift) {
        Stop(at, "file ends inside an object header (truncated)");
        return false;
      }
    }
    const uint32_t size = U32(head + 8);
    const uint32_t type = U32(head + 12);
    if (size < kBaseHeader || size > kMaxObjectBytes) {
      Stop(at, "object size " + std::to_string(size) + " out of range (corrupt file)");
      return false;
    }
    object_.resize(size);
    std::memcpy(object_.data(), head, kBaseHeader);
    if (ReadExact(object_.data() + kBaseHeader, size - kBaseHeader) != size - kBaseHeader) {
      Stop(at, "file ends inside an object of " + std::to_string(size) + " bytes (truncated)");
      return false;
    }
    if (type == kLogContainer) {
      uint8_t pad[4];
      ReadExact(pad, size % 4);  // python-can / Vector padding after a container
    }
    // Keep the undecoded tail of the previous container, append this object's content.
    if (pos_ > 0) {
      inner_.erase(inner_.begin(), inner_.begin() + static_cast<ptrdiff_t>(pos_));
      pos_ = 0;
    }
    if (inner_.empty()) inner_origin_ = at;
    if (type != kLogContainer) {  // an object outside a container
      inner_.insert(inner_.end(), object_.begin(), object_.end());
      return true;
    }
    if (size < kBaseHeader + 16) {
      Reject(at, "log container shorter than its header");
      continue;
    }
    const uint16_t method = U16(object_.data() + kBaseHeader);
    const uint32_t uncompressed = U32(object_.data() + kBaseHeader + 8);
    const uint8_t* data = object_.data() + kBaseHeader + 16;
    const size_t data_bytes = size - kBaseHeader - 16;
    if (method == 0) {
      inner_.insert(inner_.end(), data, data + data_bytes);
      return true;
    }
    if (method != 2) {
      Reject(at, "log container with unknown compression method");
      continue;
    }
    if (uncompressed > kMaxUncompressed || uncompressed > data_bytes * 1100 + 1024) {  // deflate: at most ~1032:1
      Reject(at, "log container uncompressed size out of range");
      continue;
    }
    const size_t old = inner_.size();
    inner_.resize(old + uncompressed);
    uLongf out_len = uncompressed;
    const int z = uncompress(inner_.data() + old, &out_len, data, static_cast<uLong>(data_bytes));
    if (z != Z_OK || out_len != uncompressed) {
      inner_.resize(old);
      Reject(at, "log container does not decompress (corrupt zlib data)");
      // The object stream lost a piece: drop the partial object at the front as well.
      inner_.clear();
      pos_ = 0;
      continue;
    }
    return true;
  }
}

bool BlfReader::Decode(const uint8_t* obj, uint32_t size, CanFrame& frame) noexcept {
  const uint16_t header_size = U16(obj + 4);
  const uint16_t version = U16(obj + 6);
  const uint32_t type = U32(obj + 12);
  if (type != kCanMessage && type != kCanMessage2 && type != kCanFdMessage && type != kCanFdMessage64 &&
      type != kCanErrorExt) {
    Skip();
    return false;
  }
  if ((version != 1 && version != 2) || header_size < kBaseHeader + 16 || header_size > size) {
    Reject(inner_origin_, "object header of unknown version or size");
    return false;
  }
  const uint32_t flags = U32(obj + 16);
  const uint64_t time = U64(obj + 24);
  const int64_t unit = flags == 1 ? 10'000 : 1;
  if (time > static_cast<uint64_t>(INT64_MAX / 10'000 / 2)) {
    Reject(inner_origin_, "object time out of range");
    return false;
  }
  if (!AddTime(start_ns_, static_cast<int64_t>(time) * unit, frame.timestamp_ns)) {
    Reject(inner_origin_, "object time out of range");
    return false;
  }
  const uint8_t* body = obj + header_size;
  const uint32_t body_size = size - header_size;
  uint32_t channel = 0;
  uint32_t raw_id = 0;
  switch (type) {
    case kCanMessage:
    case kCanMessage2: {
      if (body_size < 16) {
        Reject(inner_origin_, "CAN_MESSAGE object too short");
        return false;
      }
      channel = U16(body);
      const uint8_t msg_flags = body[2];
      const uint8_t dlc = body[3];
      raw_id = U32(body + 4);
      frame.len = dlc > 8 ? 8 : dlc;
      if (msg_flags & 0x80) frame.flags |= kFlagRemote;
      else std::memcpy(frame.data.data(), body + 8, frame.len);
      break;
    }
    case kCanFdMessage: {
      if (body_size < 84) {
        Reject(inner_origin_, "CAN_FD_MESSAGE object too short");
        return false;
      }
      channel = U16(body);
      const uint8_t msg_flags = body[2];
      const uint8_t dlc = body[3];
      raw_id = U32(body + 4);
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
      break;
    }
    case kCanFdMessage64: {
      if (body_size < 40) {
        Reject(inner_origin_, "CAN_FD_MESSAGE_64 object too short");
        return false;
      }
      channel = body[0];
      const uint8_t dlc = body[1];
      const uint8_t valid = body[2];
      raw_id = U32(body + 4);
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
        break;
      }
      // Bytes present in the object (the rest of a short object reads as zero, as CANoe does).
      // An extended-data offset past the object's end (a damaged or hostile file) ends the data at
      // the object's end: nothing beyond the object is read.
      const uint32_t end =
          ext_offset != 0 && ext_offset >= header_size + 40u ? std::min<uint32_t>(ext_offset - header_size, body_size) : body_size;
      const uint32_t present = end > 40 ? end - 40 : 0;
      std::memcpy(frame.data.data(), body + 40, present < frame.len ? present : frame.len);
      break;
    }
    case kCanErrorExt: {
      if (body_size < 4) {
        Reject(inner_origin_, "CAN_ERROR_EXT object too short");
        return false;
      }
      channel = U16(body);
      frame.flags = kFlagError;
      frame.id = kVectorErrorClass;
      frame.len = 8;
      break;
    }
    default:
      return false;
  }
  if (type != kCanErrorExt) {
    frame.id = raw_id & kExtendedIdMask;
    if (raw_id & kExtendedIdBit) {
      frame.flags |= kFlagExtended;
    } else if (frame.id > kStandardIdMask) {
      Reject(inner_origin_, "standard identifier above 0x7FF");
      return false;
    }
  }
  const int bus = BusForChannel(channel == 0 ? 0 : channel - 1);
  if (bus < 0) {
    Reject(inner_origin_, "channel number above 256");
    return false;
  }
  frame.bus = static_cast<uint16_t>(bus);
  return true;
}

bool BlfReader::Next(CanFrame& frame) noexcept {
  for (;;) {
    // Skip padding to the next "LOBJ" (at most 7 bytes).
    size_t avail = inner_.size() - pos_;
    size_t skip = 0;
    while (skip < avail && skip < 8 && inner_[pos_ + skip] != 'L') ++skip;
    if (avail - skip >= kBaseHeader) {
      const uint8_t* obj = inner_.data() + pos_ + skip;
      if (skip >= 8 || std::memcmp(obj, "LOBJ", 4) != 0) {
        Reject(inner_origin_, "no object signature \"LOBJ\" in a container; resynchronising");
        // find the next signature in the data we have
        const uint8_t* start = inner_.data() + pos_ + 1;
        const uint8_t* stop = inner_.data() + inner_.size();
        const uint8_t* hit = nullptr;
        for (const uint8_t* p = start; p + 4 <= stop; ++p) {
          if (std::memcmp(p, "LOBJ", 4) == 0) {
            hit = p;
            break;
          }
        }
        pos_ = hit != nullptr ? static_cast<size_t>(hit - inner_.data()) : inner_.size();
        continue;
      }
      const uint32_t size = U32(obj + 8);
      if (size < kBaseHeader || size > kMaxObjectBytes) {
        Reject(inner_origin_, "object size out of range; resynchronising");
        pos_ += skip + 4;
        continue;
      }
      if (avail - skip >= size) {
        pos_ += skip + size;
        frame = CanFrame{};
        if (Decode(obj, size, frame)) return true;
        continue;
      }
    }
    if (at_end_ || stopped()) break;
    if (!LoadMore()) at_end_ = true;
  }
  // Whatever is left must be padding.
  for (size_t i = pos_; i < inner_.size(); ++i) {
    if (inner_[i] != 0) {
      Stop(inner_origin_, "the last container ends inside an object (truncated)");
      break;
    }
  }
  pos_ = inner_.size();
  return false;
}

}  // namespace

std::unique_ptr<FrameLog> OpenBlfLog(const std::string& path) { return std::make_unique<BlfReader>(path); }

}  // namespace ndsid::can::detail
