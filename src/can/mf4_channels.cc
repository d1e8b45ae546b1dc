// MDF 4 blocks read here (little endian):
//   CG links: next CG, first CN, acquisition name, ...; data: u64 record id, u64 cycle count,
//     u16 flags (bit 0 VLSD group), u16 path separator, 4 reserved, u32 data bytes, u32
//     invalidation bytes
//   CN links: next CN, composition, name, source, conversion, data (VLSD: signal data or a
//     VLSD CG), ...; data: u8 type (0 fixed, 1 VLSD, 2 master, 3 virtual master, 6 virtual
//     data), u8 sync type (1 time), u8 data type, u8 bit offset, u32 byte offset, u32 bit count
//   CC data: u8 type, u8 precision, u16 flags, u16 ref count, u16 value count, f64 phys min,
//     f64 phys max, f64 values[value count]
#include "mf4_channels.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "ndsid/common/error.h"

namespace ndsid::can::detail {
namespace {

uint32_t U32(const uint8_t* p) { return p[0] | p[1] << 8 | p[2] << 16 | static_cast<uint32_t>(p[3]) << 24; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

// A VLSD channel's record field (the offset of its value in the signal data; its data type
// is the value's): an unsigned little-endian integer of 8 to 64 bits in the record.
bool VlsdOffsetFits(const Mf4Field& f, uint32_t record_bytes) {
  if (f.bit_count < 8 || f.bit_count > 64) return false;
  Mf4Field stored = f;
  stored.cn_type = kCnFixed;
  stored.data_type = 0;
  return stored.FitsIn(record_bytes);
}

constexpr size_t kMaxConversionValues = 4096;

// Table without interpolation: the value of the nearest key, the lower one on a tie.
double NearestKey(const std::vector<double>& v, double x) noexcept {
  const size_t n = v.size() / 2;
  size_t best = 0;
  for (size_t i = 1; i < n; ++i) {
    if (std::fabs(x - v[2 * i]) < std::fabs(x - v[2 * best])) best = i;
  }
  return v[2 * best + 1];
}

double Interpolate(const std::vector<double>& v, double x) noexcept {
  const size_t n = v.size() / 2;
  if (x <= v[0]) return v[1];
  for (size_t i = 1; i < n; ++i) {
    if (x < v[2 * i]) {
      const double x0 = v[2 * i - 2], x1 = v[2 * i], y0 = v[2 * i - 1], y1 = v[2 * i + 1];
      return x1 > x0 ? y0 + (y1 - y0) * (x - x0) / (x1 - x0) : y1;
    }
  }
  return v[2 * n - 1];
}

double Ranges(const std::vector<double>& v, double x, bool integer) noexcept {
  const size_t n = (v.size() - 1) / 3;
  for (size_t i = 0; i < n; ++i) {
    const double lo = v[3 * i], hi = v[3 * i + 1];
    if (x >= lo && (integer ? x <= hi : x < hi)) return v[3 * i + 2];
  }
  return v[3 * n];  // the default value
}

}  // namespace

double Mf4Conversion::Apply(double x) const noexcept {
  const std::vector<double>& v = values;
  switch (type) {
    case 1: return v.size() >= 2 ? v[0] + v[1] * x : x;
    case 2:
      if (v.size() >= 6) return (v[0] * x * x + v[1] * x + v[2]) / (v[3] * x * x + v[4] * x + v[5]);
      return x;
    case 4: return v.size() >= 2 ? Interpolate(v, x) : x;
    case 5: return v.size() >= 2 ? NearestKey(v, x) : x;
    case 6: return v.size() >= 1 ? Ranges(v, x, x == std::floor(x)) : x;
    default: return x;
  }
}

uint64_t Mf4Field::Bits(const uint8_t* rec) const noexcept {
  uint64_t v = 0;
  const uint32_t bytes = (bit_offset + bit_count + 7) / 8;
  if ((data_type == 1 || data_type == 3) && cn_type != kCnVlsd) {
    for (uint32_t i = 0; i < bytes; ++i) v = v << 8 | rec[byte_offset + i];
    v >>= (bytes * 8 - bit_offset - bit_count);
  } else {
    for (uint32_t i = bytes; i > 0; --i) v = v << 8 | rec[byte_offset + i - 1];
    v >>= bit_offset;
  }
  return bit_count >= 64 ? v : v & ((uint64_t{1} << bit_count) - 1);
}

double Mf4Field::Raw(const uint8_t* rec, uint64_t index) const noexcept {
  if (virtual_value()) return static_cast<double>(index);
  if (data_type == 4 || data_type == 5) {
    uint8_t b[8];
    const uint32_t n = bit_count / 8;
    for (uint32_t i = 0; i < n; ++i) b[i] = rec[byte_offset + (data_type == 4 ? i : n - 1 - i)];
    if (n == 8) {
      double d;
      std::memcpy(&d, b, 8);
      return d;
    }
    float f;
    std::memcpy(&f, b, 4);
    return f;
  }
  const uint64_t bits = Bits(rec);
  if ((data_type == 2 || data_type == 3) && bit_count < 64 && (bits >> (bit_count - 1)) & 1) {
    return static_cast<double>(static_cast<int64_t>(bits | ~((uint64_t{1} << bit_count) - 1)));
  }
  if (data_type == 2 || data_type == 3) return static_cast<double>(static_cast<int64_t>(bits));
  return static_cast<double>(bits);
}

double Mf4Field::Value(const uint8_t* rec, uint64_t index) const noexcept { return cc.Apply(Raw(rec, index)); }

bool Mf4Field::Integer(const uint8_t* rec, uint64_t index, uint64_t fallback, uint64_t& out) const noexcept {
  if (!present) {
    out = fallback;
    return true;
  }
  if (!virtual_value() && data_type <= 1 && cc.identity()) {  // the common case: no floating point
    out = Bits(rec);
    return true;
  }
  const double v = Value(rec, index);
  if (!std::isfinite(v) || v < 0 || v >= 18446744073709551615.0) return false;
  out = static_cast<uint64_t>(std::llround(v));
  return true;
}

bool Mf4Field::FitsIn(uint32_t record_bytes) const noexcept {
  if (!present || virtual_value()) return true;
  const uint64_t start = byte_offset;
  const uint64_t bits = bit_count;
  if (data_type == 10) return bit_offset == 0 && bits % 8 == 0 && start + bits / 8 <= record_bytes;
  if (data_type == 4 || data_type == 5) return (bits == 32 || bits == 64) && bit_offset == 0 && start + bits / 8 <= record_bytes;
  if (data_type > 3) return false;
  return bits >= 1 && bit_offset < 8 && bit_offset + bits <= 64 && start + (bit_offset + bits + 7) / 8 <= record_bytes;
}

std::string Mf4CanGroup::Problem() const {
  if (record_bytes == 0) return "record size out of range";
  if (!time.present) return "no time master with a numeric conversion";
  if (!id.present && kind != Mf4GroupKind::kError) return "no ID channel";
  if (bytes.present && bytes.cn_type == kCnVlsd && bytes.data_link == 0) return "DataBytes stored as VLSD without signal data";
  if (bytes.present && bytes.cn_type != kCnVlsd && bytes.data_type != 10) return "DataBytes is not a byte array";
  for (const Mf4Field* f : {&time, &bus, &id, &ide, &dlc, &length, &bytes, &edl, &brs, &esi}) {
    if (f->present && f->cn_type == kCnVlsd && f != &bytes) return "a channel other than DataBytes is stored as VLSD";
    if (f->cn_type == kCnVlsd ? !VlsdOffsetFits(*f, record_bytes) : !f->FitsIn(record_bytes)) {
      return "a channel lies outside the record or has an unsupported type";
    }
  }
  return {};
}

std::string Mf4ChannelReader::Text(uint64_t at) const {
  if (at == 0) return {};
  std::string why;
  auto tx = ReadMf4Block(file_, at, true, why);
  if (!tx || !tx->Is("##TX") || tx->data.empty()) return {};
  const auto* p = reinterpret_cast<const char*>(tx->data.data());
  return std::string(p, strnlen(p, tx->data.size()));
}

Mf4Conversion Mf4ChannelReader::Conversion(uint64_t cc_at) const {
  Mf4Conversion c;
  if (cc_at == 0) return c;
  std::string why;
  auto cc = ReadMf4Block(file_, cc_at, true, why);
  if (!cc || !cc->Is("##CC") || cc->data.size() < 24) {
    c.type = 255;  // unreadable: no numeric conversion
    return c;
  }
  c.type = cc->data[0];
  const size_t count = cc->data[6] | cc->data[7] << 8;
  const size_t fit = (cc->data.size() - 24) / 8;
  c.values.resize(std::min({count, fit, kMaxConversionValues}));
  if (!c.values.empty()) std::memcpy(c.values.data(), cc->data.data() + 24, 8 * c.values.size());
  return c;
}

void Mf4ChannelReader::Collect(uint64_t cn_at, Mf4CanGroup& g, bool& is_can, int depth) {
  for (int n = 0; cn_at != 0 && n < 10000 && depth < 4; ++n) {
    if (!linked_.insert(cn_at).second) throw Error("MF4 log " + path_ + ": a channel list loops back to byte " + std::to_string(cn_at));
    std::string why;
    auto cn = ReadMf4Block(file_, cn_at, true, why);
    if (!cn || !cn->Is("##CN") || cn->data.size() < 16) return;
    const std::string name = Text(cn->Link(2));
    const uint8_t* d = cn->data.data();
    Mf4Field f;
    f.present = true;
    f.cn_type = d[0];
    f.data_type = d[2];
    f.bit_offset = d[3];
    f.byte_offset = U32(d + 4);
    f.bit_count = U32(d + 8);
    f.data_link = cn->Link(5);
    f.cc = Conversion(cn->Link(4));
    if ((f.cn_type == kCnMaster || f.cn_type == kCnVirtualMaster) && d[1] == 1) {  // the time master
      g.time = f;
      if (!f.cc.numeric()) g.time.present = false;  // a conversion we do not apply: no usable time
    } else {
      const size_t dot = name.rfind('.');
      const std::string head = dot == std::string::npos ? name : name.substr(0, dot);
      const std::string leaf = dot == std::string::npos ? name : name.substr(dot + 1);
      if (head == "CAN_DataFrame" || head == "CAN_RemoteFrame" || head == "CAN_ErrorFrame") {
        is_can = true;
        g.kind = head == "CAN_DataFrame" ? Mf4GroupKind::kData
                 : head == "CAN_RemoteFrame" ? Mf4GroupKind::kRemote
                                             : Mf4GroupKind::kError;
        if (leaf == "BusChannel") g.bus = f;
        else if (leaf == "ID") g.id = f;
        else if (leaf == "IDE") g.ide = f;
        else if (leaf == "DLC") g.dlc = f;
        else if (leaf == "DataLength") g.length = f;
        else if (leaf == "DataBytes") g.bytes = f;
        else if (leaf == "EDL") g.edl = f;
        else if (leaf == "BRS") g.brs = f;
        else if (leaf == "ESI") g.esi = f;
      }
      if (cn->Link(1) != 0) Collect(cn->Link(1), g, is_can, depth + 1);  // composition
    }
    cn_at = cn->Link(0);
  }
}

bool Mf4ChannelReader::Describe(const Mf4Block& cg, Mf4CanGroup& g) {
  if (cg.data.size() < 32) return false;
  const uint8_t* d = cg.data.data();
  g.offset = cg.offset;
  g.record_id = U64(d);
  g.cycles = U64(d + 8);
  const uint64_t bytes = uint64_t{U32(d + 24)} + U32(d + 28);
  g.record_bytes = bytes > kMaxMf4RecordBytes ? 0 : static_cast<uint32_t>(bytes);
  bool is_can = false;
  Collect(cg.Link(1), g, is_can, 0);
  return is_can;
}

}  // namespace ndsid::can::detail
