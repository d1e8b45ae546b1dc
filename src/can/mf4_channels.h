// ASAM MDF 4 channels of the CAN bus-logging groups: where a value sits in a record (or that
// it is virtual), its conversion, and the description of a CAN channel group gathered from
// its channel blocks (CAN_DataFrame / CAN_RemoteFrame / CAN_ErrorFrame with their leaves).
#pragma once

#include <cstdint>
#include <string>
#include <unordered_set>
#include <vector>

#include "mf4_blocks.h"

namespace ndsid::can::detail {

// A conversion (CC block) of the kinds that give numbers: 0 identity, 1 linear, 2 rational,
// 4 table with interpolation, 5 table without (the nearest key, asammdf's rule), 6 ranges to
// value. Text conversions (7 and up) leave the raw value, as asammdf does with
// ignore_value2text_conversions.
struct Mf4Conversion {
  uint8_t type = 0;
  std::vector<double> values;  // cc_val

  double Apply(double x) const noexcept;
  // True for the numeric kinds above (a time master needs one).
  bool numeric() const noexcept { return type <= 2 || (type >= 4 && type <= 6); }
  bool identity() const noexcept { return type == 0 || (type == 1 && values.size() >= 2 && values[0] == 0 && values[1] == 1); }
};

// cn_type values used here.
inline constexpr uint8_t kCnFixed = 0, kCnVlsd = 1, kCnMaster = 2, kCnVirtualMaster = 3, kCnVirtualData = 6;

// Where one value sits in a record.
struct Mf4Field {
  bool present = false;
  uint8_t cn_type = kCnFixed;  // kCnVirtual*: the value is the conversion of the record index
  uint8_t data_type = 0;       // 0/1 unsigned LE/BE, 2/3 signed LE/BE, 4/5 float LE/BE, 10 bytes
  uint8_t bit_offset = 0;
  uint32_t byte_offset = 0;
  uint32_t bit_count = 0;
  uint64_t data_link = 0;      // VLSD: the signal data (SD / DZ / DL / HL) or a VLSD channel group
  Mf4Conversion cc;

  bool virtual_value() const noexcept { return cn_type == kCnVirtualData || cn_type == kCnVirtualMaster; }
  // The stored bits as an unsigned number (no sign extension, no conversion).
  uint64_t Bits(const uint8_t* record) const noexcept;
  // The raw number: the stored value (signed and float types read as such) or, for a virtual
  // channel, the record index.
  double Raw(const uint8_t* record, uint64_t index) const noexcept;
  // The physical value: Raw with the conversion applied.
  double Value(const uint8_t* record, uint64_t index) const noexcept;
  // The physical value as an unsigned integer; `fallback` when absent; false when negative or
  // not finite.
  bool Integer(const uint8_t* record, uint64_t index, uint64_t fallback, uint64_t& out) const noexcept;
  // The field fits in a record of `record_bytes` with a supported type.
  bool FitsIn(uint32_t record_bytes) const noexcept;
};

enum class Mf4GroupKind { kData, kRemote, kError };

// A CAN bus-logging channel group.
struct Mf4CanGroup {
  Mf4GroupKind kind = Mf4GroupKind::kData;
  uint64_t offset = 0;          // the CG block (for messages)
  uint64_t record_id = 0;
  uint64_t cycles = 0;
  uint32_t record_bytes = 0;    // data + invalidation bytes
  Mf4Field time, bus, id, ide, dlc, length, bytes, edl, brs, esi;
  uint64_t records_read = 0;    // also the index of the next record (virtual channels)

  // Empty when the group can be read, else why not.
  std::string Problem() const;
};

// Reads channel lists. `linked` holds the blocks read so far: a link back to one is a loop.
class Mf4ChannelReader {
 public:
  Mf4ChannelReader(const Mf4File& file, std::unordered_set<uint64_t>& linked, std::string path)
      : file_(file), linked_(linked), path_(std::move(path)) {}
  // Fills `group` from the channels of the CG block `cg`; false when it is no CAN group.
  bool Describe(const Mf4Block& cg, Mf4CanGroup& group);
  // The text of a TX block ("" for none).
  std::string Text(uint64_t at) const;

 private:
  void Collect(uint64_t cn_at, Mf4CanGroup& g, bool& is_can, int depth);
  Mf4Conversion Conversion(uint64_t cc_at) const;

  const Mf4File& file_;
  std::unordered_set<uint64_t>& linked_;
  std::string path_;
};

}  // namespace ndsid::can::detail
