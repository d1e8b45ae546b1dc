// ASAM MDF 4 building blocks for the MF4 bus-logging reader: block headers with links and
// data, and the byte stream of a data group's records or of a channel's signal data (DT / SD,
// DZ deflate / transposed deflate, DL lists, HL headers), read block by block so a file is
// never loaded whole; with the rules for unfinalised files that asammdf applies.
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
inline constexpr uint32_t kMaxMf4RecordBytes = 1u << 16;  // a CAN frame record is well under 200 bytes

// The unfinalised flags of the identification block (id_unfin_flags) this reader acts on.
inline constexpr uint16_t kUnfinCycleCounts = 0x01;  // CG cycle counts not written
inline constexpr uint16_t kUnfinLastDt = 0x04;       // the last DT block's length not written
inline constexpr uint16_t kUnfinLastDl = 0x10;       // the last DL block's links not written
inline constexpr uint16_t kUnfinVlsdOffsets = 0x40;  // VLSD offsets not written

// The offset of the first block signature ("##" + a block id + 4 zero bytes, at a multiple of
// 8) at or after `from`, or the file size: where asammdf ends a block whose length is not
// written.
uint64_t FindNextMf4Block(const Mf4File& file, uint64_t from) noexcept;

// The bytes of a data group's records (or of a channel's signal data), in order, across
// whatever block structure holds them.
class Mf4DataStream {
 public:
  // `unfinalised` are the identification block's flags when the file is unfinalised: with
  // kUnfinLastDt the last DT block runs to the next block or the end of the file, with
  // kUnfinLastDl the empty links of the last DL are the data blocks that follow it.
  Mf4DataStream(const Mf4File& file, uint64_t data_link, uint16_t unfinalised = 0)
      : file_(&file), unfinalised_(unfinalised) {
    if (data_link != 0) pending_.push_back(data_link);
  }
  // Copies exactly n bytes; false at the end of the data or on an error (then error() is set).
  bool Read(uint8_t* out, size_t n) noexcept;
  // Skips n bytes (same result as Read into a scratch buffer).
  bool SkipBytes(uint64_t n) noexcept;
  const std::string& error() const noexcept { return error_; }
  // File offset of the block being read (for located messages).
  uint64_t block_offset() const noexcept { return block_offset_; }
  // Bytes delivered (read or skipped) so far.
  uint64_t position() const noexcept { return position_; }

 private:
  size_t avail() const noexcept { return buffer_.size() - pos_; }
  bool Refill() noexcept;  // next piece of data into buffer_; false at end or on error
  bool ReadDtPiece() noexcept;
  bool StartDt(uint64_t data_at, uint64_t data_bytes) noexcept;
  bool InflateDz(uint64_t data_at, uint64_t data_bytes) noexcept;
  void ExpandList(const Mf4Block& dl) noexcept;
  bool Fail(const std::string& why) noexcept;

  const Mf4File* file_;
  uint16_t unfinalised_ = 0;
  std::deque<uint64_t> pending_;  // blocks still to visit (DT, SD, DZ, DL, HL)
  std::unordered_set<uint64_t> visited_;  // blocks read: a list that links back is refused, not looped
  std::vector<uint8_t> buffer_;   // current piece
  size_t pos_ = 0;
  uint64_t position_ = 0;
  uint64_t dt_next_ = 0, dt_left_ = 0;  // the unread part of a DT block in the file
  bool dt_open_ = false;  // the DT block has no written length: it ends at the next block signature
  uint64_t block_offset_ = 0;
  bool cut_ = false;  // the DT block being read ends beyond the end of the file
  std::string error_;
};

}  // namespace ndsid::can::detail
