#include "mf4_blocks.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <cstring>

namespace ndsid::can::detail {
namespace {

constexpr size_t kBlockHeader = 24;              // id[4], reserved[4], u64 length, u64 link count
constexpr uint64_t kMaxInflated = 64u << 20;     // larger DZ blocks are refused (asammdf writes 4 MiB)
constexpr size_t kDtChunk = 1 << 18;

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

bool Mf4DataStream::Refill() noexcept {
  try {
    if (pos_ > 0) {  // keep the unread tail
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<ptrdiff_t>(pos_));
      pos_ = 0;
    }
    for (;;) {
      if (dt_left_ > 0) {  // continue the DT block being streamed
        const size_t n = dt_left_ < kDtChunk ? static_cast<size_t>(dt_left_) : kDtChunk;
        const size_t old = buffer_.size();
        buffer_.resize(old + n);
        if (!file_->ReadAt(dt_next_, buffer_.data() + old, n)) return Fail("cannot read a data block (truncated?)");
        dt_next_ += n;
        dt_left_ -= n;
        return true;
      }
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
      if (b->Is("##DT")) {
        dt_next_ = data_at;
        dt_left_ = data_bytes;
        if (data_at > file_->size() || data_bytes > file_->size() - data_at) {  // a cut block:
          dt_left_ = data_at > file_->size() ? 0 : file_->size() - data_at;       // read what is there
          cut_ = true;
        }
        continue;
      }
      if (b->Is("##DZ")) {
        if (data_bytes < 24) return Fail("DZ block too short");
        uint8_t h[24];
        if (!file_->ReadAt(data_at, h, sizeof h)) return Fail("cannot read a DZ block");
        if (h[0] != 'D' || h[1] != 'T') return Fail("DZ block holds a block type other than DT");
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
        std::vector<uint8_t> in(packed);
        if (!file_->ReadAt(data_at + 24, in.data(), packed)) return Fail("cannot read a DZ block");
        std::vector<uint8_t> out(original);
        uLongf out_len = static_cast<uLongf>(original);
        if (uncompress(out.data(), &out_len, in.data(), static_cast<uLong>(packed)) != Z_OK || out_len != original) {
          return Fail("DZ block does not decompress (corrupt deflate data)");
        }
        // Transposition: rows x columns stored column by column. Fewer bytes than columns make
        // no row: those are kept as stored, without a loop over up to 2^32 empty columns.
        if (zip_type == 1 && columns > 0 && columns <= original) {
          const uint64_t rows = original / columns;
          std::vector<uint8_t> t(out.size());
          for (uint64_t c = 0; c < columns; ++c) {
            for (uint64_t r = 0; r < rows; ++r) t[r * columns + c] = out[c * rows + r];
          }
          std::memcpy(t.data() + rows * columns, out.data() + rows * columns, original - rows * columns);
          out.swap(t);
        } else if (zip_type != 0 && zip_type != 1) {
          return Fail("DZ block with an unknown zip type");
        }
        buffer_.insert(buffer_.end(), out.begin(), out.end());
        return true;
      }
      if (b->Is("##DL")) {  // links: the next DL, then this list's data blocks
        std::deque<uint64_t> front;
        for (size_t i = 1; i < b->links.size(); ++i) {
          if (b->links[i] != 0) front.push_back(b->links[i]);
        }
        if (b->Link(0) != 0) front.push_back(b->Link(0));
        pending_.insert(pending_.begin(), front.begin(), front.end());
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
  while (avail() < n) {
    if (!Refill()) return false;
  }
  std::memcpy(out, buffer_.data() + pos_, n);
  pos_ += n;
  return true;
}

bool Mf4DataStream::SkipBytes(size_t n) noexcept {
  while (avail() < n) {
    n -= avail();
    pos_ = buffer_.size();
    if (!Refill()) return false;
  }
  pos_ += n;
  return true;
}

}  // namespace ndsid::can::detail
