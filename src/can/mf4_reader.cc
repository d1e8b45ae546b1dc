// MF4 structure used here (ASAM MDF 4.1; little endian):
//   ID block (64 bytes): "MDF     " (or "UnFinMF " while a logger writes it), "4.11    ", ...,
//     u16 version @28, u16 unfinalised flags @60, u16 custom unfinalised flags @62
//   HD at byte 64: links first DG, ...; data: u64 start time [ns since 1970], i16 tz, i16 dst, u8 flags
//   DG links: next DG, first CG, data; data: u8 record id size (0 = sorted)
//   CG, CN, CC: mf4_channels.cc
// A frame's time is HD start + the master channel's seconds. BusChannel N is bus "can<N>".
//
// Unfinalised files (version 4.10 and later, unfinalised flags set: a stand-alone logger's
// file as it was written, or one cut by a power loss) are read as asammdf reads them: cycle
// counts not written (flag 0x01) are ignored and the data read to its end; the last DT block
// without a written length (0x04) runs to the next block or the end of the file, and a record
// cut there is dropped; the last DL's links not written (0x10) are the data blocks after it;
// VLSD offsets not written (0x40) are matched by order.
#include "mf4_reader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <memory>

#include "mf4_blocks.h"
#include "mf4_channels.h"
#include "mf4_vlsd.h"
#include "ndsid/common/error.h"

namespace ndsid::can::detail {
namespace {

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
uint32_t U32(const uint8_t* p) { return U16(p) | static_cast<uint32_t>(U16(p + 2)) << 16; }
uint64_t U64(const uint8_t* p) { return U32(p) | static_cast<uint64_t>(U32(p + 4)) << 32; }

constexpr size_t kMaxQueued = 4096;  // frames waiting for their VLSD value

// A frame decoded from its record, waiting (when its DataBytes come from a VLSD channel
// group) for its value.
struct QueuedFrame {
  CanFrame frame;
  bool ready = true;
  int vlsd = -1;        // index in Cursor::vlsd of the group holding its DataBytes
  uint64_t key = 0;     // the value's key in that group
  uint64_t at = 0;      // file offset of the data block its record was in
};

// One data group: its record stream, the CAN groups in it, and the frames decoded from it.
struct Cursor {
  std::unique_ptr<Mf4DataStream> stream;
  uint8_t record_id_bytes = 0;
  std::vector<Mf4CanGroup> groups;                     // the CAN groups
  std::vector<int> group_vlsd;                         // per group: its VLSD group index, or -1
  std::vector<std::unique_ptr<Mf4SignalData>> signal;  // per group: its signal data, or null
  std::vector<Mf4VlsdGroup> vlsd;                      // the VLSD channel groups
  std::vector<bool> vlsd_used;                         // per VLSD group: a CAN group's DataBytes
  std::vector<std::pair<uint64_t, uint64_t>> other;    // record id -> bytes of other groups
  std::vector<uint8_t> record;
  std::deque<QueuedFrame> queue;                       // in record order; the front goes out first
  bool done = false;
};

// What a record was.
enum class RecordOutcome { kFrame, kValue, kSkipped, kRejected, kEnd };

class Mf4Reader final : public FrameLogBase {
 public:
  explicit Mf4Reader(const std::string& path) : FrameLogBase(path, LogFormat::kMf4, true) {
    if (!file_.Open(path)) throw Error("MF4 log " + path + ": cannot open: " + std::strerror(errno));
    ReadIdentification();
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
  void ReadIdentification();
  bool Next(CanFrame& frame) noexcept override;
  // Unknown: the data blocks of several groups are read interleaved, and the metadata often
  // sits at the end of the file, so no single offset measures progress.
  uint64_t RawOffset() const noexcept override { return kUnknownOffset; }
  void AddDataGroup(const Mf4Block& dg);
  // Links a CAN group's VLSD DataBytes to a VLSD group of the data group, or to signal data.
  void LinkDataBytes(Cursor& c, const std::vector<std::pair<uint64_t, uint64_t>>& vlsd_groups);
  // Reads records until the front frame is ready or the data ends.
  void Advance(Cursor& c) noexcept;
  RecordOutcome ReadRecord(Cursor& c) noexcept;
  RecordOutcome ReadValue(Cursor& c, size_t v) noexcept;
  // Decodes a CAN record into a queued frame; nullptr, or why it is malformed.
  const char* Decode(Cursor& c, size_t gi, uint64_t index, QueuedFrame& q) noexcept;
  const char* DecodeData(Cursor& c, size_t gi, int len, QueuedFrame& q) noexcept;
  void FinishCursor(Cursor& c) noexcept;

  Mf4File file_;
  int64_t start_ns_ = 0;
  uint16_t unfinalised_ = 0;  // the identification block's unfinalised flags (MDF 4.10 and later)
  bool found_can_group_ = false;
  // Offsets of the DG, CG and CN blocks read: each belongs to one list, so a link back to one is
  // a loop (a crafted file), refused instead of read again and again.
  std::unordered_set<uint64_t> linked_;
  std::vector<Cursor> cursors_;
};

void Mf4Reader::ReadIdentification() {
  uint8_t id[64];
  if (!file_.ReadAt(0, id, sizeof id) || (std::memcmp(id, "MDF     ", 8) != 0 && std::memcmp(id, "UnFinMF ", 8) != 0)) {
    throw Error("MF4 log " + path() + ": no MDF identification block");
  }
  const uint16_t version = U16(id + 28);
  if (version < 400) {
    throw ConfigError(path() + ": MDF version " + std::to_string(version) +
                      " (MDF 3) is not read; convert it to MDF 4 (asammdf: MDF(f).convert('4.10').save(...))");
  }
  if (version >= 410) unfinalised_ = U16(id + 60);  // asammdf acts on them from 4.10 on
}

void Mf4Reader::AddDataGroup(const Mf4Block& dg) {
  if (dg.data.empty()) return;
  Cursor c;
  c.record_id_bytes = dg.data[0];
  if (c.record_id_bytes != 0 && c.record_id_bytes != 1 && c.record_id_bytes != 2 && c.record_id_bytes != 4 &&
      c.record_id_bytes != 8) {
    throw Error("MF4 log " + path() + ": data group at byte " + std::to_string(dg.offset) + ": bad record id size");
  }
  const bool ignore_cycles = (unfinalised_ & kUnfinCycleCounts) != 0;
  Mf4ChannelReader channels(file_, linked_, path());
  std::vector<std::pair<uint64_t, uint64_t>> vlsd_groups;  // CG offset -> record id
  std::string why;
  for (uint64_t cg_at = dg.Link(1), n = 0; cg_at != 0 && n < 10000; ++n) {
    if (!linked_.insert(cg_at).second) throw Error("MF4 log " + path() + ": a channel group list loops back to byte " + std::to_string(cg_at));
    auto cg = ReadMf4Block(file_, cg_at, true, why);
    if (!cg || !cg->Is("##CG")) throw Error("MF4 log " + path() + ": bad channel group: " + why);
    cg_at = cg->Link(0);
    if (cg->data.size() < 32) continue;
    const uint8_t* d = cg->data.data();
    Mf4CanGroup g;
    if ((U16(d + 16) & 1) != 0) {  // a VLSD group: its records are u32 length + bytes
      vlsd_groups.emplace_back(cg->offset, U64(d));
      continue;
    }
    if (!channels.Describe(*cg, g)) {
      c.other.emplace_back(U64(d), uint64_t{U32(d + 24)} + U32(d + 28));
      continue;
    }
    const std::string problem = g.Problem();
    if (!problem.empty()) throw ConfigError(path() + ": CAN group at byte " + std::to_string(cg->offset) + ": " + problem);
    found_can_group_ = true;
    if (g.cycles > 0 || c.record_id_bytes != 0 || ignore_cycles) c.groups.push_back(g);
  }
  if (c.groups.empty()) return;  // decoded signals or an empty group: nothing to read
  if (c.record_id_bytes == 0 && c.groups.size() + c.other.size() + vlsd_groups.size() > 1) {
    throw Error("MF4 log " + path() + ": sorted data group at byte " + std::to_string(dg.offset) + " with several channel groups");
  }
  LinkDataBytes(c, vlsd_groups);
  c.stream = std::make_unique<Mf4DataStream>(file_, dg.Link(2), unfinalised_);
  cursors_.push_back(std::move(c));
}

void Mf4Reader::LinkDataBytes(Cursor& c, const std::vector<std::pair<uint64_t, uint64_t>>& vlsd_groups) {
  for (const auto& entry : vlsd_groups) c.vlsd.emplace_back(entry.second, (unfinalised_ & kUnfinVlsdOffsets) != 0);
  c.vlsd_used.assign(c.vlsd.size(), false);
  for (const Mf4CanGroup& g : c.groups) {
    int vlsd = -1;
    std::unique_ptr<Mf4SignalData> signal;
    if (g.bytes.present && g.bytes.cn_type == kCnVlsd) {
      for (size_t i = 0; i < vlsd_groups.size(); ++i) {
        if (vlsd_groups[i].first == g.bytes.data_link) vlsd = static_cast<int>(i);
      }
      if (vlsd < 0) signal = std::make_unique<Mf4SignalData>(file_, g.bytes.data_link);
      else c.vlsd_used[static_cast<size_t>(vlsd)] = true;
    }
    c.group_vlsd.push_back(vlsd);
    c.signal.push_back(std::move(signal));
  }
}

const char* Mf4Reader::DecodeData(Cursor& c, size_t gi, int len, QueuedFrame& q) noexcept {
  const Mf4CanGroup& g = c.groups[gi];
  const uint8_t* r = c.record.data();
  CanFrame& f = q.frame;
  f.len = static_cast<uint8_t>(len);
  if (!g.bytes.present) return len > 0 ? "data length above the DataBytes channel's size" : nullptr;
  if (g.bytes.cn_type != kCnVlsd) {
    if (len > static_cast<int>(g.bytes.bit_count / 8)) return "data length above the DataBytes channel's size";
    if (len > 0) std::memcpy(f.data.data(), r + g.bytes.byte_offset, static_cast<size_t>(len));
    return nullptr;
  }
  const uint64_t offset = g.bytes.Bits(r);
  Mf4VlsdValue value;
  if (c.group_vlsd[gi] < 0) {  // signal data blocks
    if (const char* why = c.signal[gi]->Read(offset, value)) return why;
  } else {  // a VLSD channel group: the value may have come already, or comes later
    Mf4VlsdGroup& v = c.vlsd[static_cast<size_t>(c.group_vlsd[gi])];
    q.key = v.FrameKey(offset);
    if (!v.Take(q.key, value)) {
      q.ready = false;
      q.vlsd = c.group_vlsd[gi];
      return nullptr;
    }
  }
  if (len > static_cast<int>(value.bytes.size())) return "data length above the DataBytes value's size";
  if (len > 0) std::memcpy(f.data.data(), value.bytes.data(), static_cast<size_t>(len));
  return nullptr;
}

const char* Mf4Reader::Decode(Cursor& c, size_t gi, uint64_t index, QueuedFrame& q) noexcept {
  const Mf4CanGroup& g = c.groups[gi];
  const uint8_t* r = c.record.data();
  CanFrame& f = q.frame;
  const double t = g.time.Value(r, index);
  if (!std::isfinite(t) || std::fabs(t) > 9e9) return "record with a non-finite or out-of-range time";
  if (!AddTime(start_ns_, std::llround(t * 1e9), f.timestamp_ns)) return "record time out of range";
  uint64_t bus = 0;
  if (!g.bus.Integer(r, index, 0, bus)) return "BusChannel is not a channel number";
  const int bus_index = BusForChannel(bus);
  if (bus_index < 0) return "more than 256 BusChannel values in one file";
  f.bus = static_cast<uint16_t>(bus_index);
  if (g.kind == Mf4GroupKind::kError) {
    f.flags = kFlagError;
    f.id = kVectorErrorClass;
    f.len = 8;
    return nullptr;
  }
  uint64_t raw_id = 0, ide = 0, edl = 0, brs = 0, esi = 0, dlc_raw = 0, length = 0;
  if (!g.id.Integer(r, index, 0, raw_id) || !g.ide.Integer(r, index, 0, ide) || !g.edl.Integer(r, index, 0, edl) ||
      !g.brs.Integer(r, index, 0, brs) || !g.esi.Integer(r, index, 0, esi) || !g.dlc.Integer(r, index, 0, dlc_raw)) {
    return "a frame channel's value is negative or not finite";
  }
  const bool extended = ide != 0 || (raw_id & 0x80000000u) != 0;
  f.id = static_cast<uint32_t>(raw_id & kExtendedIdMask);
  if (extended) f.flags |= kFlagExtended;
  if (!extended && f.id > kStandardIdMask) return "standard identifier above 0x7FF";
  const bool fd = edl != 0;
  const int dlc = g.dlc.present ? static_cast<int>(dlc_raw & 0xF) : -1;
  const uint64_t from_dlc = dlc < 0 ? 8 : fd ? FdDlcToLength(dlc) : (dlc > 8 ? 8 : dlc);
  if (!g.length.Integer(r, index, from_dlc, length)) return "DataLength is negative or not finite";
  if (length > (fd ? 64u : 8u)) return "data length above the frame's maximum";
  if (fd) f.flags |= kFlagFd | (brs != 0 ? kFlagFdBrs : 0) | (esi != 0 ? kFlagFdEsi : 0);
  if (g.kind == Mf4GroupKind::kRemote) {
    f.flags |= kFlagRemote;
    f.len = static_cast<uint8_t>(dlc < 0 ? 0 : dlc > 8 ? 8 : dlc);
    return nullptr;
  }
  return DecodeData(c, gi, static_cast<int>(length), q);
}

RecordOutcome Mf4Reader::ReadValue(Cursor& c, size_t v) noexcept {
  uint8_t head[4];
  if (!c.stream->Read(head, sizeof head)) return RecordOutcome::kEnd;
  const uint32_t length = U32(head);
  if (length > kMaxVlsdBytes) {
    Stop(c.stream->block_offset(), "VLSD value longer than 1 MiB in an unsorted data group (corrupt data)");
    return RecordOutcome::kEnd;
  }
  Mf4VlsdValue value;
  value.length = length;
  value.bytes.resize(std::min<uint32_t>(length, kMaxPayload));
  if (!c.stream->Read(value.bytes.data(), value.bytes.size()) || !c.stream->SkipBytes(length - value.bytes.size())) {
    return RecordOutcome::kEnd;
  }
  if (!c.vlsd_used[v]) {  // the values of a group that is not a frame's DataBytes
    Skip();
    return RecordOutcome::kSkipped;
  }
  Mf4VlsdGroup& group = c.vlsd[v];
  const uint64_t key = group.NextValueKey(length);
  for (QueuedFrame& q : c.queue) {
    if (!q.ready && q.vlsd == static_cast<int>(v) && q.key == key) {
      const int len = q.frame.len;
      if (len > static_cast<int>(value.bytes.size())) {
        q.frame.len = 0;
        q.vlsd = -2;  // rejected when it reaches the front
      } else if (len > 0) {
        std::memcpy(q.frame.data.data(), value.bytes.data(), static_cast<size_t>(len));
      }
      q.ready = true;
      return RecordOutcome::kValue;
    }
  }
  group.Keep(key, std::move(value));
  return RecordOutcome::kValue;
}

RecordOutcome Mf4Reader::ReadRecord(Cursor& c) noexcept {
  size_t gi = 0;
  if (c.record_id_bytes != 0) {
    uint8_t rid[8] = {};
    if (!c.stream->Read(rid, c.record_id_bytes)) return RecordOutcome::kEnd;
    const uint64_t id = U64(rid);
    gi = c.groups.size();
    for (size_t i = 0; i < c.groups.size(); ++i) {
      if (c.groups[i].record_id == id) gi = i;
    }
    if (gi == c.groups.size()) {
      for (size_t v = 0; v < c.vlsd.size(); ++v) {
        if (c.vlsd[v].record_id() == id) return ReadValue(c, v);
      }
      for (const auto& [other_id, bytes] : c.other) {
        if (other_id != id) continue;
        if (!c.stream->SkipBytes(bytes)) return RecordOutcome::kEnd;
        Skip();
        return RecordOutcome::kSkipped;
      }
      Stop(c.stream->block_offset(), "unknown record id " + std::to_string(id) + " in an unsorted data group (corrupt data)");
      return RecordOutcome::kEnd;
    }
  } else if ((unfinalised_ & kUnfinCycleCounts) == 0 && c.groups[0].records_read >= c.groups[0].cycles) {
    return RecordOutcome::kEnd;
  }
  Mf4CanGroup& g = c.groups[gi];
  c.record.resize(g.record_bytes);
  if (!c.stream->Read(c.record.data(), g.record_bytes)) return RecordOutcome::kEnd;
  const uint64_t index = g.records_read++;
  QueuedFrame q;
  q.at = c.stream->block_offset();
  if (const char* why = Decode(c, gi, index, q)) {
    Reject(q.at, why);
    return RecordOutcome::kRejected;
  }
  try {
    c.queue.push_back(q);
  } catch (...) {
    Reject(q.at, "out of memory");
    return RecordOutcome::kRejected;
  }
  return RecordOutcome::kFrame;
}

void Mf4Reader::FinishCursor(Cursor& c) noexcept {
  c.done = true;
  if (!c.stream->error().empty()) {
    Stop(c.stream->block_offset(), c.stream->error());
    return;
  }
  if ((unfinalised_ & kUnfinCycleCounts) != 0) return;
  for (const Mf4CanGroup& g : c.groups) {
    if (g.records_read < g.cycles) {
      Stop(c.stream->block_offset(), "data ends after " + std::to_string(g.records_read) + " of " +
                                         std::to_string(g.cycles) + " records (truncated)");
      return;
    }
  }
}

void Mf4Reader::Advance(Cursor& c) noexcept {
  for (;;) {
    while (!c.queue.empty() && c.queue.front().ready && c.queue.front().vlsd == -2) {
      Reject(c.queue.front().at, "data length above the DataBytes value's size");
      c.queue.pop_front();
    }
    if (!c.queue.empty() && c.queue.front().ready) return;
    if (!c.queue.empty() && (c.done || c.queue.size() > kMaxQueued)) {  // its value never came
      Reject(c.queue.front().at, c.done ? "DataBytes value (VLSD) missing at the end of the data"
                                        : "DataBytes value (VLSD) not found within 4096 records");
      c.queue.pop_front();
      continue;
    }
    if (c.done || stopped()) return;
    if (ReadRecord(c) == RecordOutcome::kEnd) FinishCursor(c);
  }
}

bool Mf4Reader::Next(CanFrame& frame) noexcept {
  Cursor* best = nullptr;
  for (Cursor& c : cursors_) {
    Advance(c);
    if (stopped()) return false;
    if (!c.queue.empty() && (best == nullptr || c.queue.front().frame.timestamp_ns < best->queue.front().frame.timestamp_ns)) {
      best = &c;
    }
  }
  if (best == nullptr) return false;
  frame = best->queue.front().frame;
  best->queue.pop_front();
  return true;
}

}  // namespace

std::unique_ptr<FrameLog> OpenMf4Log(const std::string& path) { return std::make_unique<Mf4Reader>(path); }

}  // namespace ndsid::can::detail
