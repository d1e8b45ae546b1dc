// BLF file layout (little endian; after python-can's blf.py and Toby Lorenz' vector_blf):
//   file header   "LOGG", u32 header size (144), ..., u64 file size @16, u64 uncompressed size,
//                 u32 object count @32, u32, SYSTEMTIME start @40 (8 x u16: year, month,
//                 weekday, day, hour, minute, second, millisecond), SYSTEMTIME stop
//   objects       "LOBJ" base header (blf_objects.h), padded to 4 bytes (object size % 4)
//   LOG_CONTAINER (type 10): base header, u16 method (0 stored, 2 zlib), 6 pad, u32
//                 uncompressed size, 4 pad, then the data: a stream of objects that may
//                 continue in the next container.
// Containers are streamed through inflate in pieces (kChunkBytes in, at most kChunkBytes out
// per step), so neither a container's size nor its compression ratio sets the memory used;
// one object is held whole (at most kMaxObjectBytes). The start time is read as UTC, as
// python-can writes it; a file without one gives times since the measurement start.
#include "blf_reader.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <deque>

#include "blf_objects.h"
#include "ndsid/common/error.h"
#include "text_time.h"

namespace ndsid::can::detail {
namespace {

constexpr size_t kFileHeaderMin = 72;
constexpr uint32_t kContainerHeaderBytes = kBlfBaseHeaderBytes + 16;
constexpr uint32_t kMaxObjectBytes = 64u << 20;  // larger objects are corrupt
constexpr size_t kChunkBytes = 1 << 17;

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t U32(const uint8_t* p) { return U16(p) | static_cast<uint32_t>(U16(p + 2)) << 16; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

bool AllZero(const uint8_t* p, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    if (p[i] != 0) return false;
  }
  return true;
}

// Where a stretch of the object stream came from: a log container's file offset, and the
// offset of the stretch's first byte in the container's data.
struct Origin {
  size_t stream_at = 0;     // index in the object stream buffer
  uint64_t file_at = 0;     // the container's file offset
  uint64_t data_at = 0;     // offset in the container's data
};

// What one step of loading gave.
enum class Step {
  kData,     // bytes were appended to the object stream
  kNothing,  // none yet (a container began or ended, a record was rejected): go on
  kEnd       // the end of the file, or a stop
};

// The log container being streamed.
struct Container {
  bool active = false;
  uint64_t file_at = 0;        // its file offset
  uint64_t left = 0;           // bytes of its data still in the file
  uint64_t produced = 0;       // bytes of object stream it gave so far
  uint32_t padding = 0;        // bytes after it (object size % 4)
  bool zlib = false;
  bool ended = false;          // zlib stream end seen
  bool out_full = false;       // the last inflate filled its output: more may be pending
  z_stream z{};
  std::vector<uint8_t> input;  // compressed bytes read, not yet inflated: z.next_in points here
};

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
    EndContainer();
    if (file_ != nullptr) gzclose(file_);
  }

 private:
  void ReadFileHeader(const std::string& path);
  bool Next(CanFrame& frame) noexcept override;
  uint64_t RawOffset() const noexcept override { return offset_; }
  size_t ReadExact(uint8_t* out, size_t n) noexcept;
  void SkipBytes(uint64_t n) noexcept;
  // Appends more of the object stream; false at the end of the file or after a stop.
  bool LoadMore() noexcept;
  Step ReadTopLevelObject() noexcept;
  // Reads a container's header and sets up its streaming.
  void StartContainer(uint64_t at, uint32_t size) noexcept;
  Step ContinueContainer() noexcept;
  Step InflateStep() noexcept;
  void FinishContainer() noexcept;
  void EndContainer() noexcept;
  // Drops the decoded front of the stream buffer.
  void Compact() noexcept;
  void NoteOrigin(uint64_t file_at, uint64_t data_at) noexcept;
  // Records a stop that takes effect once the objects already in the stream are decoded.
  void DeferStop(uint64_t at, const char* why) noexcept;
  // Rejects the object at stream index `at` with its place.
  void RejectObject(size_t at, const char* reason) noexcept;
  bool FindObject(size_t& skip, uint64_t& extent) noexcept;

  gzFile file_ = nullptr;
  uint64_t offset_ = 0;              // bytes consumed from the file
  uint64_t declared_size_ = 0;       // the file size the header states
  int64_t start_ns_ = 0;             // the header's start time (0 when it has none)
  std::vector<uint8_t> stream_;      // object stream not yet decoded: stream_[pos_, end)
  size_t pos_ = 0;
  std::deque<Origin> origins_;       // where the stretches of stream_ came from, in order
  Container container_;
  bool at_end_ = false;              // no more input
  bool stop_pending_ = false;        // reading ends at pending_stop_ once the stream is decoded
  uint64_t pending_stop_at_ = 0;
  const char* pending_stop_ = nullptr;
};

void BlfReader::ReadFileHeader(const std::string& path) {
  uint8_t header[kFileHeaderMin];
  if (ReadExact(header, sizeof header) != sizeof header || std::memcmp(header, "LOGG", 4) != 0) {
    throw Error("BLF log " + path + ": no BLF file header (truncated?)");
  }
  const uint32_t header_size = U32(header + 4);
  declared_size_ = U64(header + 16);
  const uint8_t* st = header + 40;
  if (const auto ns = CivilToNs(U16(st), U16(st + 2), U16(st + 6), U16(st + 8), U16(st + 10), U16(st + 12),
                                static_cast<int64_t>(U16(st + 14)) * 1'000'000)) {
    start_ns_ = *ns;
  }
  if (header_size < kFileHeaderMin || header_size > 4096) throw Error("BLF log " + path + ": bad header size");
  std::vector<uint8_t> rest(header_size - kFileHeaderMin);
  if (ReadExact(rest.data(), rest.size()) != rest.size()) throw Error("BLF log " + path + ": truncated header");
}

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

void BlfReader::SkipBytes(uint64_t n) noexcept {
  uint8_t scratch[4096];
  while (n > 0) {
    const size_t step = n < sizeof scratch ? static_cast<size_t>(n) : sizeof scratch;
    if (ReadExact(scratch, step) != step) return;
    n -= step;
  }
}

void BlfReader::DeferStop(uint64_t at, const char* why) noexcept {
  if (stop_pending_) return;
  stop_pending_ = true;
  pending_stop_at_ = at;
  pending_stop_ = why;
}

void BlfReader::Compact() noexcept {
  if (pos_ == 0) return;
  stream_.erase(stream_.begin(), stream_.begin() + static_cast<ptrdiff_t>(pos_));
  while (origins_.size() > 1 && origins_[1].stream_at <= pos_) origins_.pop_front();
  for (Origin& o : origins_) {
    if (o.stream_at >= pos_) {
      o.stream_at -= pos_;
    } else {  // the stretch began before the cut: advance its start to the cut
      o.data_at += pos_ - o.stream_at;
      o.stream_at = 0;
    }
  }
  pos_ = 0;
}

void BlfReader::NoteOrigin(uint64_t file_at, uint64_t data_at) noexcept {
  try {
    origins_.push_back({stream_.size(), file_at, data_at});
  } catch (...) {
  }
}

void BlfReader::RejectObject(size_t at, const char* reason) noexcept {
  const Origin* origin = nullptr;
  for (const Origin& o : origins_) {
    if (o.stream_at <= at) origin = &o;
  }
  if (origin == nullptr || !keeps_malformed()) {
    Reject(origin != nullptr ? origin->file_at : offset_, reason);
    return;
  }
  const uint64_t in_data = origin->data_at + (at - origin->stream_at);
  try {
    Reject(origin->file_at, "object at byte " + std::to_string(in_data) + " of the log container's data: " + reason);
  } catch (...) {
    Reject(origin->file_at, reason);
  }
}

bool BlfReader::LoadMore() noexcept {
  Compact();
  for (;;) {
    Step step = Step::kEnd;
    if (container_.active) {
      step = ContinueContainer();  // also after a deferred stop: inflate what was read
    } else if (!stop_pending_) {
      step = ReadTopLevelObject();
    }
    if (step == Step::kData) return true;
    if (step == Step::kEnd) return false;
  }
}

Step BlfReader::ReadTopLevelObject() noexcept {
  const uint64_t at = offset_;
  uint8_t head[kBlfBaseHeaderBytes];
  const size_t got = ReadExact(head, sizeof head);
  int err = Z_OK;
  gzerror(file_, &err);
  if (err != Z_OK && err != Z_STREAM_END) {
    DeferStop(at, "read or decompression error (truncated gzip?)");
    return Step::kEnd;
  }
  if (got == 0) {
    if (declared_size_ > offset_) DeferStop(offset_, "the file ends before the size its header states (truncated)");
    return Step::kEnd;
  }
  if (got < sizeof head) {  // zero padding at the end is fine; anything else is a cut header
    if (!AllZero(head, got)) DeferStop(at, "file ends inside an object header (truncated)");
    return Step::kEnd;
  }
  if (std::memcmp(head, "LOBJ", 4) != 0) {
    // Padding of 1..7 bytes the writer did not account for: find "LOBJ" in what was read.
    size_t shift = 1;
    while (shift < sizeof head && std::memcmp(head + shift, "LOBJ", std::min<size_t>(4, sizeof head - shift)) != 0) ++shift;
    if (shift >= 8 || !AllZero(head, shift)) {
      DeferStop(at, "no object signature \"LOBJ\" where an object must start (corrupt file)");
      return Step::kEnd;
    }
    std::memmove(head, head + shift, sizeof head - shift);
    if (ReadExact(head + sizeof head - shift, shift) != shift) {
      DeferStop(at, "file ends inside an object header (truncated)");
      return Step::kEnd;
    }
  }
  const uint32_t size = U32(head + 8);
  if (size < kBlfBaseHeaderBytes || size > kMaxObjectBytes) {
    DeferStop(at, "object size out of range (corrupt file)");
    return Step::kEnd;
  }
  if (U32(head + 12) == kBlfLogContainer) {
    StartContainer(at, size);
    return Step::kNothing;
  }
  // An object outside a container: BLF keeps every object in log containers, and neither
  // python-can nor vector_blf reads one outside. A CAN object there is rejected, others skipped.
  SkipBytes(size - sizeof head);
  if (IsBlfCanObject(U32(head + 12))) {
    Reject(at, "CAN object outside a log container (python-can and vector_blf read none)");
  } else {
    Skip();
  }
  return Step::kNothing;
}

void BlfReader::StartContainer(uint64_t at, uint32_t size) noexcept {
  if (size < kContainerHeaderBytes) {
    Reject(at, "log container shorter than its header");
    SkipBytes(size - kBlfBaseHeaderBytes);
    return;
  }
  uint8_t head[kContainerHeaderBytes - kBlfBaseHeaderBytes];
  if (ReadExact(head, sizeof head) != sizeof head) {
    DeferStop(at, "file ends inside a log container header (truncated)");
    return;
  }
  const uint16_t method = U16(head);
  const uint64_t data_bytes = size - kContainerHeaderBytes;
  if (method != 0 && method != 2) {
    Reject(at, "log container with an unknown compression method");
    SkipBytes(data_bytes + size % 4);
    return;
  }
  container_ = Container{};
  container_.file_at = at;
  container_.left = data_bytes;
  container_.padding = size % 4;
  container_.zlib = method == 2;
  if (container_.zlib && inflateInit(&container_.z) != Z_OK) {
    DeferStop(at, "out of memory");
    return;
  }
  container_.active = true;
}

Step BlfReader::ContinueContainer() noexcept {
  Container& c = container_;
  if (!c.zlib) {  // stored: copy a piece
    if (c.left == 0) {
      FinishContainer();
      return Step::kNothing;
    }
    const size_t n = c.left < kChunkBytes ? static_cast<size_t>(c.left) : kChunkBytes;
    NoteOrigin(c.file_at, c.produced);
    const size_t old = stream_.size();
    stream_.resize(old + n);
    const size_t got = ReadExact(stream_.data() + old, n);
    stream_.resize(old + got);
    c.left -= got;
    c.produced += got;
    if (got < n) {
      DeferStop(c.file_at, "file ends inside a log container (truncated)");
      EndContainer();
    }
    return got > 0 ? Step::kData : stop_pending_ ? Step::kEnd : Step::kNothing;
  }
  return InflateStep();
}

Step BlfReader::InflateStep() noexcept {
  Container& c = container_;
  for (;;) {
    if (c.z.avail_in == 0 && c.left > 0 && !c.ended) {  // more compressed input
      const size_t n = c.left < kChunkBytes ? static_cast<size_t>(c.left) : kChunkBytes;
      c.input.resize(n);
      const size_t got = ReadExact(c.input.data(), n);
      c.left -= got;
      c.z.next_in = c.input.data();
      c.z.avail_in = static_cast<uInt>(got);
      if (got < n) {
        DeferStop(c.file_at, "file ends inside a log container (truncated)");
        c.left = 0;
      }
    }
    if (c.ended || (c.z.avail_in == 0 && !c.out_full)) {  // all of it inflated (or cut)
      if (!c.ended && !stop_pending_) {
        Reject(c.file_at, "log container's zlib data ends before the end of its stream (cut container)");
      }
      FinishContainer();
      return stop_pending_ ? Step::kEnd : Step::kNothing;
    }
    const size_t old = stream_.size();
    stream_.resize(old + kChunkBytes);
    c.z.next_out = stream_.data() + old;
    c.z.avail_out = static_cast<uInt>(kChunkBytes);
    const int z = inflate(&c.z, Z_NO_FLUSH);
    const size_t produced = kChunkBytes - c.z.avail_out;
    stream_.resize(old + produced);
    if (z != Z_OK && z != Z_STREAM_END && z != Z_BUF_ERROR) {
      Reject(c.file_at, "log container does not decompress (corrupt zlib data)");
      // The object stream lost a piece: drop the partial object as well.
      stream_.clear();
      pos_ = 0;
      origins_.clear();
      SkipBytes(c.left);
      c.left = 0;
      FinishContainer();
      return stop_pending_ ? Step::kEnd : Step::kNothing;
    }
    if (produced > 0) {
      Origin o{old, c.file_at, c.produced};
      try {
        origins_.push_back(o);
      } catch (...) {
      }
      c.produced += produced;
    }
    c.ended = z == Z_STREAM_END;
    c.out_full = produced == kChunkBytes;
    if (produced > 0) return Step::kData;
  }
}

void BlfReader::FinishContainer() noexcept {
  const uint64_t rest = container_.left + container_.padding;
  EndContainer();
  SkipBytes(rest);  // data after the zlib stream's end, and the padding to 4 bytes
}

void BlfReader::EndContainer() noexcept {
  if (container_.active && container_.zlib) inflateEnd(&container_.z);
  container_.active = false;
  container_.input.clear();
  container_.input.shrink_to_fit();
}

// Finds a complete object at stream_[pos_ + skip], `extent` bytes long; false when more data
// is needed.
bool BlfReader::FindObject(size_t& skip, uint64_t& extent) noexcept {
  for (;;) {
    // Padding (at most 7 bytes) before the next "LOBJ".
    const size_t avail = stream_.size() - pos_;
    skip = 0;
    while (skip < avail && skip < 8 && stream_[pos_ + skip] != 'L') ++skip;
    if (avail - skip < kBlfBaseHeaderBytes) return false;
    const uint8_t* obj = stream_.data() + pos_ + skip;
    if (skip >= 8 || std::memcmp(obj, "LOBJ", 4) != 0) {
      RejectObject(pos_, "no object signature \"LOBJ\" in a container; resynchronising");
      const uint8_t* hit = nullptr;
      for (const uint8_t* p = stream_.data() + pos_ + 1; p + 4 <= stream_.data() + stream_.size(); ++p) {
        if (std::memcmp(p, "LOBJ", 4) == 0) {
          hit = p;
          break;
        }
      }
      pos_ = hit != nullptr ? static_cast<size_t>(hit - stream_.data()) : stream_.size();
      continue;
    }
    const uint32_t size = U32(obj + 8);
    if (size < kBlfBaseHeaderBytes || size > kMaxObjectBytes) {
      RejectObject(pos_ + skip, "object size out of range; resynchronising");
      pos_ += skip + 4;
      continue;
    }
    extent = BlfObjectExtent(obj, size, avail - skip);
    if (extent > kMaxObjectBytes) {
      RejectObject(pos_ + skip, "object size out of range; resynchronising");
      pos_ += skip + 4;
      continue;
    }
    return extent != 0 && avail - skip >= extent;
  }
}

bool BlfReader::Next(CanFrame& frame) noexcept {
  for (;;) {
    size_t skip = 0;
    uint64_t extent = 0;
    if (FindObject(skip, extent)) {
      const size_t at = pos_ + skip;
      const uint8_t* obj = stream_.data() + at;
      const uint32_t size = U32(obj + 8);
      pos_ = at + static_cast<size_t>(extent);
      frame = CanFrame{};
      const BlfDecoded d = DecodeBlfObject(obj, size, start_ns_, frame);
      if (d.verdict == BlfVerdict::kNotFrame) {
        Skip();
        continue;
      }
      if (d.verdict == BlfVerdict::kFrame) {
        const int bus = BusForChannel(d.channel == 0 ? 0 : d.channel - 1);
        if (bus >= 0) {
          frame.bus = static_cast<uint16_t>(bus);
          return true;
        }
        RejectObject(at, "more than 256 channels in one file");
        continue;
      }
      RejectObject(at, d.reason);
      continue;
    }
    if (at_end_ || stopped()) break;
    if (!LoadMore()) at_end_ = true;
  }
  if (stop_pending_) {
    Stop(pending_stop_at_, pending_stop_);
  } else if (!AllZero(stream_.data() + pos_, stream_.size() - pos_)) {  // anything left must be padding
    Stop(origins_.empty() ? offset_ : origins_.back().file_at, "the last container ends inside an object (truncated)");
  }
  pos_ = stream_.size();
  return false;
}

}  // namespace

std::unique_ptr<FrameLog> OpenBlfLog(const std::string& path) { return std::make_unique<BlfReader>(path); }

}  // namespace ndsid::can::detail
