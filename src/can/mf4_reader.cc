// MF4 structure used here (ASAM MDF 4.1; little endian):
//   ID block (64 bytes: "MDF     ", "4.10    ", ...), then HD at byte 64:
//     HD links: first DG, ...; data: u64 start time [ns since 1970], i16 tz, i16 dst, u8 flags
//   DG links: next DG, first CG, data; data: u8 record id size (0 = sorted)
//   CG links: next CG, first CN, acquisition name, ...; data: u64 record id, u64 cycle count,
//     u16 flags (bit 0 VLSD group), ..., u32 data bytes, u32 invalidation bytes
//   CN links: next CN, composition, name, source, conversion, ...; data: u8 type (2 master),
//     u8 sync type (1 time), u8 data type (0/1 uint LE/BE, 2/3 int, 4/5 float, 10 bytes),
//     u8 bit offset, u32 byte offset, u32 bit count
//   CC (conversion of the master): type 0 identity, 1 linear (value = p0 + p1 * raw)
// A frame's time is HD start + master seconds. BusChannel N is bus "can<N>".
#include "mf4_reader.h"

#include <cmath>
#include <cstring>
#include <memory>

#include "mf4_blocks.h"
#include "ndsid/common/error.h"

namespace ndsid::can::detail {
namespace {

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t U32(const uint8_t* p) { return U16(p) | static_cast<uint32_t>(U16(p + 2)) << 16; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

enum class GroupKind { kData, kRemote, kError };

constexpr uint32_t kMaxRecordBytes = 1u << 16;  // a CAN frame record is well under 200 bytes

// Where one value sits in a record.
struct Field {
  bool present = false;
  uint32_t byte_offset = 0;
  uint8_t bit_offset = 0;
  uint32_t bit_count = 0;
  uint8_t data_type = 0;  // 0/1 unsigned LE/BE, 4/5 float LE/BE, 10 bytes

  uint64_t Unsigned(const uint8_t* rec) const noexcept {
    uint64_t v = 0;
    const uint32_t bytes = (bit_offset + bit_count + 7) / 8;
    if (data_type == 1) {
      for (uint32_t i = 0; i < bytes; ++i) v = v << 8 | rec[byte_offset + i];
      v >>= (bytes * 8 - bit_offset - bit_count);
    } else {
      for (uint32_t i = bytes; i > 0; --i) v = v << 8 | rec[byte_offset + i - 1];
      v >>= bit_offset;
    }
    return bit_count >= 64 ? v : v & ((uint64_t{1} << bit_count) - 1);
  }
  double Real(const uint8_t* rec) const noexcept {
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
    return static_cast<double>(Unsigned(rec));
  }
};

struct Group {
  GroupKind kind = GroupKind::kData;
  uint64_t record_id = 0;
  uint64_t cycles = 0;
  uint32_t record_bytes = 0;  // data + invalidation bytes (kMaxRecordBytes + 1 when larger)
  uint64_t record_bytes_full = 0;
  Field time, bus, id, ide, dlc, length, bytes, edl, brs, esi;
  double time_offset = 0, time_factor = 1;  // linear conversion of the master
  uint64_t records_read = 0;
};

// One data group: its record stream and the CAN groups in it, with the next frame decoded.
struct Cursor {
  std::unique_ptr<Mf4DataStream> stream;
  uint8_t record_id_bytes = 0;
  std::vector<Group> groups;                          // the CAN groups
  std::vector<std::pair<uint64_t, int64_t>> other;    // record id -> bytes (-1: VLSD) of others
  std::vector<uint8_t> record;
  bool has_frame = false;
  bool done = false;
  CanFrame frame;
};

bool ValidField(const Field& f, uint32_t record_bytes) {
  if (!f.present) return true;
  const uint64_t start = f.byte_offset;
  const uint64_t bits = f.bit_count;
  if (f.data_type == 10) return f.bit_offset == 0 && bits % 8 == 0 && start + bits / 8 <= record_bytes;
  if (f.data_type == 4 || f.data_type == 5) return (bits == 32 || bits == 64) && f.bit_offset == 0 && start + bits / 8 <= record_bytes;
  if (f.data_type > 3) return false;
  return bits >= 1 && f.bit_offset < 8 && f.bit_offset + bits <= 64 && start + (f.bit_offset + bits + 7) / 8 <= record_bytes;
}

class Mf4Reader final : public FrameLogBase {
 public:
  explicit Mf4Reader(const std::string& path) : FrameLogBase(path, LogFormat::kMf4, true) {
    if (!file_.Open(path)) throw Error("MF4 log " + path + ": cannot open: " + std::strerror(errno));
    uint8_t id[64];
    if (!file_.ReadAt(0, id, sizeof id) || std::memcmp(id, "MDF     ", 8) != 0) {
      throw Error("MF4 log " + path + ": no MDF identification block");
    }
    const uint16_t version = U16(id + 28);
    if (version < 400) throw ConfigError(path + ": MDF version " + std::to_string(version) + " (MDF 3) is not read; convert it to MDF 4 (asammdf: MDF(f).convert('4.10').save(...))");
    std::string why;
    auto hd = ReadMf4Block(file_, 64, true, why);
    if (!hd || !hd->Is("##HD") || hd->data.size() < 8) throw Error("MF4 log " + path + ": no header block: " + why);
    start_ns_ = static_cast<int64_t>(U64(hd->data.data()));
    for (uint64_t dg_at = hd->Link(0), n = 0; dg_at != 0 && n < 100000; ++n) {
      if (!linked_.insert(dg_at).second) throw Error("MF4 log " + path + ": the data group list loops back to byte " + std::to_string(dg_at));
      auto dg = ReadMf4Block(file_, dg_at, true, why);
      if (!dg || !dg->Is("##DG")) throw Error("MF4 log " + path + ": bad data group: " + why);
      AddDataGroup(*dg);
      dg_at = dg->Link(0);
    }
    if (!found_can_group_) {
      throw ConfigError(path + ": MF4 file without a CAN bus-logging group (CAN_DataFrame); "
                        "it holds decoded signals, not frames: log the raw bus, or export frames as ASC/BLF");
    }
  }

 private:
  bool Next(CanFrame& frame) noexcept override;
  // Unknown: the data blocks of several groups are read interleaved, and the metadata often
  // sits at the end of the file, so no single offset measures progress.
  uint64_t RawOffset() const noexcept override { return kUnknownOffset; }
  void AddDataGroup(const Mf4Block& dg);
  bool DescribeGroup(const Mf4Block& cg, Group& g);
  void CollectChannels(uint64_t cn_at, Group& g, bool& is_can, int depth);
  std::string Text(uint64_t at);
  // Decodes the next frame of a cursor into c.frame; false at the end of its data.
  bool Advance(Cursor& c) noexcept;

  Mf4File file_;
  int64_t start_ns_ = 0;
  bool found_can_group_ = false;
  // Offsets of the DG, CG and CN blocks read: each belongs to one list, so a link back to one is
  // a loop (a crafted file), refused instead of read again and again.
  std::unordered_set<uint64_t> linked_;
  std::vector<Cursor> cursors_;
};

std::string Mf4Reader::Text(uint64_t at) {
  if (at == 0) return {};
  std::string why;
  auto tx = ReadMf4Block(file_, at, true, why);
  if (!tx || !tx->Is("##TX") || tx->data.empty()) return {};
  const auto* p = reinterpret_cast<const char*>(tx->data.data());
  return std::string(p, strnlen(p, tx->data.size()));
}

void Mf4Reader::CollectChannels(uint64_t cn_at, Group& g, bool& is_can, int depth) {
  for (int n = 0; cn_at != 0 && n < 10000 && depth < 4; ++n) {
    if (!linked_.insert(cn_at).second) throw Error("MF4 log " + path() + ": a channel list loops back to byte " + std::to_string(cn_at));
    std::string why;
    auto cn = ReadMf4Block(file_, cn_at, true, why);
    if (!cn || !cn->Is("##CN") || cn->data.size() < 16) return;
    const std::string name = Text(cn->Link(2));
    const uint8_t* d = cn->data.data();
    Field f;
    f.present = true;
    f.data_type = d[2];
    f.bit_offset = d[3];
    f.byte_offset = U32(d + 4);
    f.bit_count = U32(d + 8);
    const uint8_t type = d[0];
    if (type == 2 && d[1] == 1) {  // the time master
      g.time = f;
      if (cn->Link(4) != 0) {
        auto cc = ReadMf4Block(file_, cn->Link(4), true, why);
        if (cc && cc->Is("##CC") && cc->data.size() >= 40 && cc->data[0] == 1) {
          // data: u8 type, u8 precision, u16 flags, u16 ref count, u16 val count, f64 phys min,
          // f64 phys max, then the values p0, p1
          std::memcpy(&g.time_offset, cc->data.data() + 24, 8);
          std::memcpy(&g.time_factor, cc->data.data() + 32, 8);
        } else if (cc && !(cc->Is("##CC") && cc->data.size() >= 1 && cc->data[0] == 0)) {
          g.time.present = false;  // a conversion we do not apply: no usable time
          g.time.data_type = 255;
        }
      }
    } else {
      const size_t dot = name.rfind('.');
      const std::string head = dot == std::string::npos ? name : name.substr(0, dot);
      const std::string leaf = dot == std::string::npos ? name : name.substr(dot + 1);
      if (head == "CAN_DataFrame" || head == "CAN_RemoteFrame" || head == "CAN_ErrorFrame") {
        is_can = true;
        g.kind = head == "CAN_DataFrame" ? GroupKind::kData : head == "CAN_RemoteFrame" ? GroupKind::kRemote : GroupKind::kError;
        if (type == 1) f.data_type = 254;  // VLSD: not read
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
      if (cn->Link(1) != 0) CollectChannels(cn->Link(1), g, is_can, depth + 1);  // composition
    }
    cn_at = cn->Link(0);
  }
}

bool Mf4Reader::DescribeGroup(const Mf4Block& cg, Group& g) {
  if (cg.data.size() < 32) return false;
  const uint8_t* d = cg.data.data();
  g.record_id = U64(d);
  g.cycles = U64(d + 8);
  const uint64_t bytes = uint64_t{U32(d + 24)} + U32(d + 28);
  g.record_bytes = bytes > kMaxRecordBytes ? kMaxRecordBytes + 1 : static_cast<uint32_t>(bytes);
  g.record_bytes_full = bytes;
  bool is_can = false;
  CollectChannels(cg.Link(1), g, is_can, 0);
  return is_can;
}

void Mf4Reader::AddDataGroup(const Mf4Block& dg) {
  if (dg.data.empty()) return;
  Cursor c;
  c.record_id_bytes = dg.data[0];
  if (c.record_id_bytes != 0 && c.record_id_bytes != 1 && c.record_id_bytes != 2 && c.record_id_bytes != 4 &&
      c.record_id_bytes != 8) {
    throw Error("MF4 log " + path() + ": data group at byte " + std::to_string(dg.offset) + ": bad record id size");
  }
  std::string why;
  for (uint64_t cg_at = dg.Link(1), n = 0; cg_at != 0 && n < 10000; ++n) {
    if (!linked_.insert(cg_at).second) throw Error("MF4 log " + path() + ": a channel group list loops back to byte " + std::to_string(cg_at));
    auto cg = ReadMf4Block(file_, cg_at, true, why);
    if (!cg || !cg->Is("##CG")) throw Error("MF4 log " + path() + ": bad channel group: " + why);
    Group g;
    const bool vlsd = cg->data.size() >= 18 && (U16(cg->data.data() + 16) & 1) != 0;
    if (!vlsd && DescribeGroup(*cg, g)) {
      const char* problem = nullptr;
      if (g.record_bytes == 0 || g.record_bytes > kMaxRecordBytes) problem = "record size out of range";
      else if (!g.time.present) problem = "no time master with an identity or linear conversion";
      else if (!g.id.present && g.kind != GroupKind::kError) problem = "no ID channel";
      else if (g.bytes.present && g.bytes.data_type != 10) problem = "DataBytes not stored in the record (VLSD is not read)";
      for (const Field* f : {&g.time, &g.bus, &g.id, &g.ide, &g.dlc, &g.length, &g.bytes, &g.edl, &g.brs, &g.esi}) {
        if (problem == nullptr && !ValidField(*f, g.record_bytes)) problem = "a channel lies outside the record or has an unsupported type";
      }
      if (problem != nullptr) {
        throw ConfigError(path() + ": CAN group at byte " + std::to_string(cg->offset) + ": " + problem);
      }
      found_can_group_ = true;
      if (g.cycles > 0 || c.record_id_bytes != 0) c.groups.push_back(g);
    } else {
      c.other.emplace_back(vlsd ? U64(cg->data.data()) : g.record_id, vlsd ? -1 : static_cast<int64_t>(g.record_bytes_full));
    }
    cg_at = cg->Link(0);
  }
  if (c.groups.empty()) return;  // decoded signals or an empty group: nothing to read
  if (c.record_id_bytes == 0 && c.groups.size() + c.other.size() > 1) {
    throw Error("MF4 log " + path() + ": sorted data group at byte " + std::to_string(dg.offset) + " with several channel groups");
  }
  c.stream = std::make_unique<Mf4DataStream>(file_, dg.Link(2));
  cursors_.push_back(std::move(c));
}

bool Mf4Reader::Advance(Cursor& c) noexcept {
  for (;;) {
    Group* g = nullptr;
    if (c.record_id_bytes == 0) {
      g = &c.groups[0];
    } else {
      uint8_t rid[8] = {};
      if (!c.stream->Read(rid, c.record_id_bytes)) break;
      const uint64_t id = U64(rid);
      for (Group& x : c.groups) {
        if (x.record_id == id) g = &x;
      }
      if (g == nullptr) {
        int64_t bytes = -2;
        for (const auto& [rid2, size] : c.other) {
          if (rid2 == id) bytes = size;
        }
        if (bytes == -2) {
          Stop(c.stream->block_offset(), "unknown record id " + std::to_string(id) + " in an unsorted data group (corrupt data)");
          return false;
        }
        if (bytes == -1) {  // VLSD record: u32 length + bytes
          uint8_t len[4];
          if (!c.stream->Read(len, 4) || !c.stream->SkipBytes(U32(len))) break;
        } else if (!c.stream->SkipBytes(static_cast<size_t>(bytes))) {
          break;
        }
        Skip();
        continue;
      }
    }
    if (c.record_id_bytes == 0 && g->records_read >= g->cycles) break;
    c.record.resize(g->record_bytes);
    if (!c.stream->Read(c.record.data(), g->record_bytes)) break;
    ++g->records_read;
    const uint8_t* r = c.record.data();
    CanFrame& f = c.frame;
    f = CanFrame{};
    const double t = g->time_offset + g->time_factor * g->time.Real(r);
    if (!std::isfinite(t) || std::fabs(t) > 9e9) {
      Reject(c.stream->block_offset(), "record with a non-finite or out-of-range time");
      continue;
    }
    if (!AddTime(start_ns_, std::llround(t * 1e9), f.timestamp_ns)) {
      Reject(c.stream->block_offset(), "record time out of range");
      continue;
    }
    const uint64_t bus = g->bus.present ? g->bus.Unsigned(r) : 0;
    const int bus_index = BusForChannel(bus > kMaxChannel ? kMaxChannel + 1 : static_cast<uint32_t>(bus));
    if (bus_index < 0) {
      Reject(c.stream->block_offset(), "BusChannel above 255");
      continue;
    }
    f.bus = static_cast<uint16_t>(bus_index);
    if (g->kind == GroupKind::kError) {
      f.flags = kFlagError;
      f.id = kVectorErrorClass;
      f.len = 8;
      c.has_frame = true;
      return true;
    }
    const uint64_t raw_id = g->id.Unsigned(r);
    const bool extended = (g->ide.present && g->ide.Unsigned(r) != 0) || (raw_id & 0x80000000u) != 0;
    f.id = static_cast<uint32_t>(raw_id & kExtendedIdMask);
    if (extended) f.flags |= kFlagExtended;
    if (!extended && f.id > kStandardIdMask) {
      Reject(c.stream->block_offset(), "standard identifier above 0x7FF");
      continue;
    }
    const bool fd = g->edl.present && g->edl.Unsigned(r) != 0;
    const int dlc = g->dlc.present ? static_cast<int>(g->dlc.Unsigned(r) & 0xF) : -1;
    int len = g->length.present ? static_cast<int>(g->length.Unsigned(r)) : (dlc < 0 ? 8 : fd ? FdDlcToLength(dlc) : (dlc > 8 ? 8 : dlc));
    if (len > (fd ? 64 : 8)) {
      Reject(c.stream->block_offset(), "data length above the frame's maximum");
      continue;
    }
    if (fd) f.flags |= kFlagFd | (g->brs.present && g->brs.Unsigned(r) ? kFlagFdBrs : 0) | (g->esi.present && g->esi.Unsigned(r) ? kFlagFdEsi : 0);
    if (g->kind == GroupKind::kRemote) {
      f.flags |= kFlagRemote;
      f.len = static_cast<uint8_t>(dlc < 0 ? 0 : dlc > 8 ? 8 : dlc);
    } else {
      const int have = g->bytes.present ? static_cast<int>(g->bytes.bit_count / 8) : 0;
      if (len > have) {
        Reject(c.stream->block_offset(), "data length above the DataBytes channel's size");
        continue;
      }
      f.len = static_cast<uint8_t>(len);
      if (len > 0) std::memcpy(f.data.data(), r + g->bytes.byte_offset, static_cast<size_t>(len));
    }
    c.has_frame = true;
    return true;
  }
  c.done = true;
  c.has_frame = false;
  if (!c.stream->error().empty()) {
    Stop(c.stream->block_offset(), c.stream->error());
  } else {
    for (const Group& g : c.groups) {
      if (g.records_read < g.cycles) {
        Stop(c.stream->block_offset(), "data ends after " + std::to_string(g.records_read) + " of " +
                                           std::to_string(g.cycles) + " records (truncated)");
        break;
      }
    }
  }
  return false;
}

bool Mf4Reader::Next(CanFrame& frame) noexcept {
  Cursor* best = nullptr;
  for (Cursor& c : cursors_) {
    if (!c.has_frame && !c.done) Advance(c);
    if (stopped()) return false;
    if (c.has_frame && (best == nullptr || c.frame.timestamp_ns < best->frame.timestamp_ns)) best = &c;
  }
  if (best == nullptr) return false;
  frame = best->frame;
  best->has_frame = false;
  return true;
}

}  // namespace

std::unique_ptr<FrameLog> OpenMf4Log(const std::string& path) { return std::make_unique<Mf4Reader>(path); }

}  // namespace ndsid::can::detail
