// ASAM MDF 4 building blocks for the MF4 bus-logging reader: block headers with links and
// data, and the record byte stream of a data group (DT, DZ deflate / transposed deflate,
// DL lists, HL headers), read block by block so a file is never loaded whole.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <unordered_set>
#include <vector>

namespace ndsid::can::detail {

// An open file read at absolute offsets (pread).
class Mf4File {
 public:
  ~Mf4File();
  bool Open(const std::string& path) noexcept;
  // Exactly n bytes at offset, or false (beyond the end / read error).
  bool ReadAt(uint64_t offset, void* out, size_t n) const noexcept;
  uint64_t size() const noexcept { return size_; }

 private:
  int fd_ = -1;
  uint64_t size_ = 0;
};

struct Mf4Block {
  char id[4] = {};            // "##DG", ...
  uint64_t offset = 0;
  uint64_t length = 0;        // whole block, header included
  std::vector<uint64_t> links;
  std::vector<uint8_t> data;  // after the links (metadata blocks only)

  bool Is(const char* id4) const noexcept;
  uint64_t Link(size_t i) const noexcept { return i < links.size() ? links[i] : 0; }
};

// Reads the block at `offset` with its links and (when load_data) its data, at most
// kMaxMetaBytes of it. Returns an empty optional and sets `why` on any problem.
std::optional<Mf4Block> ReadMf4Block(const Mf4File& file, uint64_t offset, bool load_data, std::string& why);

inline constexpr uint64_t kMaxMetaBytes = 1u << 20;

// The bytes of a data group's records, in order, across whatever block structure holds them.
class Mf4DataStream {
 public:
  Mf4DataStream(const Mf4File& file, uint64_t data_link) : file_(&file) {
    if (data_link != 0) pending_.push_back(data_link);
  }
  // Copies exactly n bytes; false at the end of the data or on an error (then error() is set).
  bool Read(uint8_t* out, size_t n) noexcept;
  // Skips n bytes (same result as Read into a scratch buffer).
  bool SkipBytes(size_t n) noexcept;
  const std::string& error() const noexcept { return error_; }
  // File offset of the block being read (for located messages).
  uint64_t block_offset() const noexcept { return block_offset_; }
  // True when every byte was consumed and no data block was left unread.
  bool exhausted() const noexcept { return pending_.empty() && avail() == 0; }

 private:
  size_t avail() const noexcept { return buffer_.size() - pos_; }
  bool Refill() noexcept;  // next piece of data into buffer_; false at end or on error
  bool Fail(const std::string& why) noexcept;

  const Mf4File* file_;
  std::deque<uint64_t> pending_;  // blocks still to visit (DT, DZ, DL, HL)
  std::unordered_set<uint64_t> visited_;  // blocks read: a list that links back is refused, not looped
  std::vector<uint8_t> buffer_;   // current piece
  size_t pos_ = 0;
  uint64_t dt_next_ = 0, dt_left_ = 0;  // the unread part of a DT block in the file
  uint64_t block_offset_ = 0;
  bool cut_ = false;  // the DT block being read ends beyond the end of the file
  std::string error_;
};

}  // namespace ndsid::can::detail
