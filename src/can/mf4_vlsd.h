// Variable-length DataBytes (VLSD) of the MF4 bus-logging reader. A VLSD channel stores in
// its record the offset of its value, a u32 length and the bytes, in one of two places:
//   - signal data blocks (SD, or DZ / DL / HL of them) linked from the channel, as finalised
//     files keep it (Mf4SignalData: read forward by offset);
//   - a VLSD channel group in the same unsorted data group, whose records are the values, as
//     loggers such as the CANedge write them while logging (Mf4VlsdGroup: each value is
//     matched to the frame record that names its offset; the value may come before or after
//     that record).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <utility>
#include <vector>

#include "mf4_blocks.h"

namespace ndsid::can::detail {

inline constexpr uint32_t kMaxVlsdBytes = 1u << 20;  // a longer value is corrupt (CAN FD carries 64)

// A value: its length and (at most kMaxPayload of) its bytes.
struct Mf4VlsdValue {
  uint32_t length = 0;
  std::vector<uint8_t> bytes;
};

class Mf4SignalData {
 public:
  Mf4SignalData(const Mf4File& file, uint64_t link) : file_(file), link_(link) {}
  // The value at `offset`; nullptr, or why it cannot be read. Offsets that go backwards
  // restart the block chain from the first block.
  const char* Read(uint64_t offset, Mf4VlsdValue& out) noexcept;

 private:
  const Mf4File& file_;
  uint64_t link_;
  std::unique_ptr<Mf4DataStream> stream_;
};

// A VLSD channel group of an unsorted data group.
class Mf4VlsdGroup {
 public:
  // `by_order`: the offsets in the frame records were never written (unfinalised flag
  // kUnfinVlsdOffsets): the n-th value belongs to the n-th frame record.
  Mf4VlsdGroup(uint64_t record_id, bool by_order) : record_id_(record_id), by_order_(by_order) {}
  uint64_t record_id() const noexcept { return record_id_; }
  // The key of a value that arrives now (its offset, or its ordinal), advancing past it.
  uint64_t NextValueKey(uint32_t length) noexcept;
  // The key a frame record refers to (its offset field, or the next ordinal).
  uint64_t FrameKey(uint64_t offset_field) noexcept { return by_order_ ? frames_++ : offset_field; }
  // Keeps a value no frame has claimed yet (the oldest are dropped beyond kMaxUnclaimed).
  void Keep(uint64_t key, Mf4VlsdValue value) noexcept;
  // Takes the kept value of `key`; false when there is none.
  bool Take(uint64_t key, Mf4VlsdValue& out) noexcept;

  static constexpr size_t kMaxUnclaimed = 256;

 private:
  uint64_t record_id_;
  bool by_order_;
  uint64_t next_offset_ = 0;   // the offset of the next value (the sum of 4 + length before it)
  uint64_t values_ = 0;        // values seen
  uint64_t frames_ = 0;        // frame records that referred to a value (by_order_)
  std::deque<std::pair<uint64_t, Mf4VlsdValue>> unclaimed_;
};

}  // namespace ndsid::can::detail
