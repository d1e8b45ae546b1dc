// A minimal MF4 writer for the reader's tests, after the layout comments of src/can/mf4_*.cc:
// blocks are appended to a byte string and linked by their offsets, so hand-made, unfinalised
// and broken files can be built block by block.
#pragma once

#include <zlib.h>

#include <cstring>
#include <string>
#include <vector>

#include "log_test_util.h"

namespace ndsid::can::testing {

inline std::string F64(double v) {
  std::string s(8, '\0');
  std::memcpy(s.data(), &v, 8);
  return s;
}

// A channel of a CAN group: cn_type 0 fixed, 1 VLSD, 2 master, 6 virtual data.
struct Mf4ChannelSpec {
  std::string name;
  uint8_t cn_type = 0;
  uint8_t data_type = 0;  // 0 uint LE, 4 float LE, 10 bytes
  uint32_t byte = 0;
  uint8_t bit = 0;
  uint32_t bits = 0;
  uint64_t conversion = 0;  // a CC block
  uint64_t data = 0;        // VLSD: the signal data or VLSD CG block
};

class Mf4Writer {
 public:
  // ID block ("MDF     " or, with unfinalised flags, "UnFinMF ") and an HD block with the start time.
  explicit Mf4Writer(int64_t start_ns, uint16_t unfinalised = 0) {
    bytes_ = std::string(unfinalised != 0 ? "UnFinMF " : "MDF     ") + "4.11    ndsid   " + std::string(4, '\0') +
             Le<uint16_t>(411);
    bytes_.resize(60, '\0');
    bytes_ += Le<uint16_t>(unfinalised) + Le<uint16_t>(0);
    Add(Block("##HD", {0, 0, 0, 0, 0, 0}, Le<uint64_t>(static_cast<uint64_t>(start_ns)) + std::string(24, '\0')));
  }
  static std::string Block(const char* id, const std::vector<uint64_t>& links, const std::string& data) {
    std::string b = std::string(id, 4) + std::string(4, '\0') + Le<uint64_t>(24 + 8 * links.size() + data.size()) +
                    Le<uint64_t>(links.size());
    for (uint64_t l : links) b += Le(l);
    return b + data;
  }
  // Appends a block (padded to 8 bytes); returns its offset.
  uint64_t Add(const std::string& block) {
    bytes_.resize((bytes_.size() + 7) / 8 * 8, '\0');
    const uint64_t at = bytes_.size();
    bytes_ += block;
    return at;
  }
  uint64_t Text(const std::string& text) {
    std::string t = text + '\0';
    t.resize((t.size() + 7) / 8 * 8, '\0');
    return Add(Block("##TX", {}, t));
  }
  // A CC block: 1 linear (p0, p1), 5 table without interpolation (key, value pairs), ...
  uint64_t Conversion(uint8_t type, const std::vector<double>& values) {
    std::string data = Le(type) + Le<uint8_t>(0) + Le<uint16_t>(0) + Le<uint16_t>(0) +
                       Le<uint16_t>(static_cast<uint16_t>(values.size())) + std::string(16, '\0');
    for (double v : values) data += F64(v);
    return Add(Block("##CC", {0, 0, 0, 0}, data));
  }
  // The channel list of a group (one flat list, as the reader takes the leaves "CAN_DataFrame.X"
  // from any list), in the order given; returns the first channel's offset.
  uint64_t Channels(const std::vector<Mf4ChannelSpec>& specs) {
    uint64_t next = 0;
    for (auto it = specs.rbegin(); it != specs.rend(); ++it) next = Channel(*it, next, 0);
    return next;
  }
  uint64_t Channel(const Mf4ChannelSpec& c, uint64_t next, uint64_t composition) {
    const uint64_t name = Text(c.name);
    const std::string data = Le(c.cn_type) + Le<uint8_t>(c.cn_type == 2 ? 1 : 0) + Le(c.data_type) + Le(c.bit) +
                             Le(c.byte) + Le(c.bits) + std::string(12, '\0') + Le<uint8_t>(0) + Le<uint8_t>(0) +
                             Le<uint16_t>(0) + std::string(48, '\0');
    return Add(Block("##CN", {next, composition, name, 0, c.conversion, c.data, 0, 0}, data));
  }
  // A CG block; flags bit 0 marks a VLSD group.
  uint64_t Group(uint64_t next, uint64_t first_channel, uint64_t record_id, uint64_t cycles, uint32_t bytes,
                 uint16_t flags = 0) {
    return Add(Block("##CG", {next, first_channel, 0, 0, 0, 0},
                     Le(record_id) + Le(cycles) + Le(flags) + Le<uint16_t>(0) + Le<uint32_t>(0) + Le(bytes) + Le<uint32_t>(0)));
  }
  // A DG block (record id size 0 = sorted) linked into the HD's list of data groups.
  uint64_t DataGroup(uint64_t first_group, uint64_t data, uint8_t record_id_bytes) {
    const uint64_t at = Add(Block("##DG", {0, first_group, data, 0}, Le(record_id_bytes) + std::string(7, '\0')));
    uint64_t link_at = 64 + 24;  // HD's first DG, then each DG's next
    for (uint64_t dg = ReadLink(link_at); dg != 0; dg = ReadLink(link_at)) link_at = dg + 24;
    std::memcpy(bytes_.data() + link_at, &at, 8);
    return at;
  }
  // Sets link `index` of the block at `block` (DG data links are often known only later).
  void SetLink(uint64_t block, size_t index, uint64_t value) { std::memcpy(bytes_.data() + block + 24 + 8 * index, &value, 8); }
  // A DZ block holding `data` deflated (zip type 0) as a block of type "DT" or "SD".
  static std::string Dz(const std::string& original_type, const std::string& data) {
    uLongf n = compressBound(static_cast<uLong>(data.size()));
    std::string packed(n, '\0');
    compress2(reinterpret_cast<Bytef*>(packed.data()), &n, reinterpret_cast<const Bytef*>(data.data()),
              static_cast<uLong>(data.size()), 6);
    packed.resize(n);
    return Block("##DZ", {}, original_type + Le<uint8_t>(0) + Le<uint8_t>(0) + Le<uint32_t>(0) +
                                 Le<uint64_t>(data.size()) + Le<uint64_t>(packed.size()) + packed);
  }
  std::string& bytes() { return bytes_; }

  // Sets `bits` bits at byte `byte`, bit `bit` of a little-endian record to `value`.
  static void Put(std::string& record, uint32_t byte, uint8_t bit, uint32_t bits, uint64_t value) {
    for (uint32_t i = 0; i < bits; ++i) {
      const uint32_t at = bit + i;
      auto& b = reinterpret_cast<uint8_t&>(record[byte + at / 8]);
      if ((value >> i) & 1) b = static_cast<uint8_t>(b | (1u << (at % 8)));
    }
  }

 private:
  uint64_t ReadLink(uint64_t at) const {
    uint64_t v = 0;
    std::memcpy(&v, bytes_.data() + at, 8);
    return v;
  }
  std::string bytes_;
};

}  // namespace ndsid::can::testing
