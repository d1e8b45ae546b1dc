#include "mf4_blocks.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>

namespace ndsid::can::detail {
namespace {

constexpr size_t kBlockHeader = 24;              // id[4], reserved[4], u64 length, u64 link count
constexpr uint64_t kMaxInflated = 64u << 20;     // larger DZ blocks are refused (asammdf writes 4 MiB)
constexpr size_t kDtChunk = 1 << 18;      // a multiple of 8: pieces keep the 8-byte block alignment
constexpr size_t kScanChunk = 1 << 16;

// A block signature at p (8 bytes): "##", a block id of the MDF 4 set, 4 zero bytes (the
// pattern asammdf looks for when it finalises a file).
bool IsBlockSignature(const uint8_t* p) {
  if (p[0] != '#' || p[1] != '#' || p[4] != 0 || p[5] != 0 || p[6] != 0 || p[7] != 0) return false;
  static constexpr const char* kIds[] = {"DG", "DV", "DT", "DZ", "DI", "DL", "AT", "CA", "CG", "CH", "CN", "CC",
                                         "EV", "FH", "HL", "LD", "MD", "RD", "RV", "RI", "SI", "SR", "SD", "TX", "GD"};
  for (const char* id : kIds) {
    if (p[2] == id[0] && p[3] == id[1]) return true;
  }
  return false;
}

uint32_t U32(const uint8_t* p) { return p[0] | p[1] << 8 | p[2] << 16 | static_cast<uint32_t>(p[3]) << 24; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

}  // namespace

Mf4File::~Mf4File() {
  if (fd_ >= 0) ::close(fd_);
}

bool Mf4File::Open(const std::string& path) noexcept {
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) return false;
  struct stat st {};
  if (::fstat(fd_, &st) != 0) return false;
  size_ = static_cast<uint64_t>(st.st_size);
  return true;
}

bool Mf4File::ReadAt(uint64_t offset, void* out, size_t n) const noexcept {
  if (offset > size_ || n > size_ - offset) return false;
  auto* p = static_cast<uint8_t*>(out);
  while (n > 0) {
    const ssize_t r = ::pread(fd_, p, n, static_cast<off_t>(offset));
    if (r <= 0) return false;
    p += r;
    offset += static_cast<uint64_t>(r);
    n -= static_cast<size_t>(r);
  }
  return true;
}

bool Mf4Block::Is(const char* id4) const noexcept { return std::memcmp(id, id4, 4) == 0; }

std::optional<Mf4Block> ReadMf4Block(const Mf4File& file, uint64_t offset, bool load_data, std::string& why) {
  uint8_t head[kBlockHeader];
  if (!file.ReadAt(offset, head, sizeof head)) {
    why = "block at byte " + std::to_string(offset) + " lies beyond the end of the file (truncated?)";
    return std::nullopt;
  }
  Mf4Block b;
  std::memcpy(b.id, head, 4);
  if (b.id[0] != '#' || b.id[1] != '#') {
    why = "no block at byte " + std::to_string(offset) + " (link into nowhere)";
    return std::nullopt;
  }
  b.offset = offset;
  b.length = U64(head + 8);
  const uint64_t link_count = U64(head + 16);
  if (b.length < kBlockHeader || link_count > (b.length - kBlockHeader) / 8 || link_count > 1'000'000) {
    why = "block at byte " + std::to_string(offset) + " has an impossible length or link count";
    return std::nullopt;
  }
  if (load_data && b.length > file.size() - offset) {
    why = "block at byte " + std::to_string(offset) + " ends beyond the end of the file (truncated)";
    return std::nullopt;
  }
  b.links.resize(link_count);
  std::vector<uint8_t> raw(link_count * 8);
  if (!file.ReadAt(offset + kBlockHeader, raw.data(), raw.size())) {
    why = "cannot read the links of the block at byte " + std::to_string(offset);
    return std::nullopt;
  }
  for (size_t i = 0; i < link_count; ++i) b.links[i] = U64(raw.data() + 8 * i);
  if (load_data) {
    const uint64_t data_bytes = b.length - kBlockHeader - 8 * link_count;
    if (data_bytes > kMaxMetaBytes) {
      why = "block at byte " + std::to_string(offset) + " is too large for a metadata block";
      return std::nullopt;
    }
    b.data.resize(data_bytes);
    if (!file.ReadAt(offset + kBlockHeader + 8 * link_count, b.data.data(), data_bytes)) {
      why = "cannot read the block at byte " + std::to_string(offset);
      return std::nullopt;
    }
  }
  return b;
}

uint64_t FindNextMf4Block(const Mf4File& file, uint64_t from) noexcept {
  uint64_t at = (from + 7) / 8 * 8;
  uint8_t chunk[kScanChunk];
  while (at + 8 <= file.size()) {
    const size_t n = static_cast<size_t>(std::min<uint64_t>(kScanChunk, (file.size() - at) / 8 * 8));
    if (!file.ReadAt(at, chunk, n)) break;
    for (size_t i = 0; i + 8 <= n; i += 8) {
      if (IsBlockSignature(chunk + i)) return at + i;
    }
    at += n;
  }
  return file.size();
}

bool Mf4DataStream::Fail(const std::string& why) noexcept {
  try {
    error_ = why;
  } catch (...) {
  }
  pending_.clear();
  dt_left_ = 0;
  buffer_.clear();
  pos_ = 0;
  return false;
}

bool Mf4DataStream::ReadDtPiece() noexcept {
  const size_t n = dt_left_ < kDtChunk ? static_cast<size_t>(dt_left_) : kDtChunk;
  const size_t old = buffer_.size();
  buffer_.resize(old + n);
  if (!file_->ReadAt(dt_next_, buffer_.data() + old, n)) return Fail("cannot read a data block (truncated?)");
  size_t keep = n;
  if (dt_open_) {  // ends at the first block signature (8-byte aligned in the file)
    for (size_t i = (8 - dt_next_ % 8) % 8; i + 8 <= n; i += 8) {
      if (IsBlockSignature(buffer_.data() + old + i)) {
        keep = i;
        dt_left_ = n;
        break;
      }
    }
  }
  buffer_.resize(old + keep);
  dt_next_ += n;
  dt_left_ -= n;
  return true;
}

bool Mf4DataStream::StartDt(uint64_t data_at, uint64_t data_bytes) noexcept {
  dt_next_ = data_at;
  dt_left_ = data_bytes;
  dt_open_ = false;
  const bool last = pending_.empty();
  if (last && (unfinalised_ & kUnfinLastDt) != 0) {  // its length was never written: up to the end
    dt_left_ = data_at > file_->size() ? 0 : file_->size() - data_at;
    dt_open_ = true;
  } else if (data_at > file_->size() || data_bytes > file_->size() - data_at) {  // a cut block:
    dt_left_ = data_at > file_->size() ? 0 : file_->size() - data_at;            // read what is there
    cut_ = true;
  }
  return true;
}

bool Mf4DataStream::InflateDz(uint64_t data_at, uint64_t data_bytes) noexcept {
  if (data_bytes < 24) return Fail("DZ block too short");
  uint8_t h[24];
  if (!file_->ReadAt(data_at, h, sizeof h)) return Fail("cannot read a DZ block");
  if (!((h[0] == 'D' && h[1] == 'T') || (h[0] == 'S' && h[1] == 'D'))) return Fail("DZ block holds a block type other than DT or SD");
  const uint8_t zip_type = h[2];
  const uint32_t columns = U32(h + 4);
  const uint64_t original = U64(h + 8);
  const uint64_t packed = U64(h + 16);
  if (data_at > file_->size() || data_bytes > file_->size() - data_at) {
    return Fail("a DZ block ends beyond the end of the file (truncated)");
  }
  if (original > kMaxInflated || packed > data_bytes - 24 || original > packed * 1100 + 1024) {
    return Fail("DZ block sizes out of range");  // deflate expands at most ~1032:1
  }
  if (zip_type != 0 && zip_type != 1) return Fail("DZ block with an unknown zip type");
  std::vector<uint8_t> in(packed);
  if (!file_->ReadAt(data_at + 24, in.data(), packed)) return Fail("cannot read a DZ block");
  std::vector<uint8_t> out(original);
  uLongf out_len = static_cast<uLongf>(original);
  if (uncompress(out.data(), &out_len, in.data(), static_cast<uLong>(packed)) != Z_OK || out_len != original) {
    return Fail("DZ block does not decompress (corrupt deflate data)");
  }
  // Transposition: rows x columns stored column by column. Fewer bytes than columns make no
  // row: those are kept as stored, without a loop over up to 2^32 empty columns.
  if (zip_type == 1 && columns > 0 && columns <= original) {
    const uint64_t rows = original / columns;
    std::vector<uint8_t> t(out.size());
    for (uint64_t c = 0; c < columns; ++c) {
      for (uint64_t r = 0; r < rows; ++r) t[r * columns + c] = out[c * rows + r];
    }
    std::memcpy(t.data() + rows * columns, out.data() + rows * columns, original - rows * columns);
    out.swap(t);
  }
  buffer_.insert(buffer_.end(), out.begin(), out.end());
  return true;
}

// DL links: the next DL, then this list's data blocks. In an unfinalised file (kUnfinLastDl)
// the last DL's links that were not written yet are the DT / DZ blocks that follow it in the
// file, one after the other (asammdf's rule).
void Mf4DataStream::ExpandList(const Mf4Block& dl) noexcept {
  std::deque<uint64_t> front;
  size_t i = 1;
  for (; i < dl.links.size() && dl.links[i] != 0; ++i) front.push_back(dl.links[i]);
  if (i < dl.links.size() && dl.Link(0) == 0 && (unfinalised_ & kUnfinLastDl) != 0) {
    uint64_t at = FindNextMf4Block(*file_, dl.offset + dl.length);
    for (; i < dl.links.size() && at + 24 <= file_->size(); ++i) {
      std::string why;
      auto b = ReadMf4Block(*file_, at, false, why);
      if (!b || !(b->Is("##DT") || b->Is("##DZ") || b->Is("##SD"))) break;
      if (b->Is("##DZ") && b->length > file_->size() - at) break;  // a cut compressed block
      front.push_back(at);
      at = FindNextMf4Block(*file_, at + 8);
    }
  }
  if (dl.Link(0) != 0) front.push_back(dl.Link(0));
  pending_.insert(pending_.begin(), front.begin(), front.end());
}

bool Mf4DataStream::Refill() noexcept {
  try {
    if (pos_ > 0) {  // keep the unread tail
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<ptrdiff_t>(pos_));
      pos_ = 0;
    }
    for (;;) {
      if (dt_left_ > 0) return ReadDtPiece();  // continue the DT block being streamed
      if (cut_) return Fail("a data block ends beyond the end of the file (truncated)");
      if (pending_.empty()) return false;
      const uint64_t at = pending_.front();
      pending_.pop_front();
      block_offset_ = at;
      // Every data block is linked once; a link back (a DL list or HL pointing at a block read
      // before) would repeat the same records forever.
      if (!visited_.insert(at).second) return Fail("a data block list links back to a block read before (a loop)");
      std::string why;
      auto b = ReadMf4Block(*file_, at, false, why);
      if (!b) return Fail(why);
      const uint64_t data_at = at + 24 + 8 * b->links.size();
      const uint64_t data_bytes = b->length - 24 - 8 * b->links.size();
      if (b->Is("##DT") || b->Is("##SD")) {
        StartDt(data_at, data_bytes);
        continue;
      }
      if (b->Is("##DZ")) return InflateDz(data_at, data_bytes);
      if (b->Is("##DL")) {
        ExpandList(*b);
        continue;
      }
      if (b->Is("##HL")) {
        if (b->Link(0) != 0) pending_.push_front(b->Link(0));
        continue;
      }
      return Fail(std::string("unsupported data block ") + std::string(b->id + 2, 2));
    }
  } catch (...) {
    return Fail("out of memory");
  }
}

bool Mf4DataStream::Read(uint8_t* out, size_t n) noexcept {
  if (n == 0) return true;  // (an empty value: no copy from or to a null pointer)
  while (avail() < n) {
    if (!Refill()) return false;
  }
  std::memcpy(out, buffer_.data() + pos_, n);
  pos_ += n;
  position_ += n;
  return true;
}

bool Mf4DataStream::SkipBytes(uint64_t n) noexcept {
  while (avail() < n) {
    n -= avail();
    position_ += avail();
    pos_ = buffer_.size();
    if (!Refill()) return false;
  }
  pos_ += static_cast<size_t>(n);
  position_ += n;
  return true;
}

}  // namespace ndsid::can::detail
