// The MF4 reader on files as stand-alone loggers write them, built block by block: unfinalised
// ("UnFinMF ", cycle counts and the last DT block's length never written, the file cut
// mid-record by a power loss), unsorted with DataBytes in a VLSD channel group (values before
// and after their frame records), virtual channels and table conversions (BusChannel, IDE and
// EDL constant per group, DataLength from the DLC), the last DL's links not written, VLSD
// offsets not written, and a finalised sorted file with deflated data and signal data blocks.
#include <gtest/gtest.h>

#include "log_test_util.h"
#include "mf4_test_util.h"
#include "ndsid/can/frame_log.h"

namespace ndsid::can {
namespace {

using namespace testing;  // NOLINT

constexpr int64_t kStartNs = 1607975914'000'000'000LL;
constexpr uint16_t kCycles = 0x01, kLastDt = 0x04, kLastDl = 0x10, kVlsdBytes = 0x20, kVlsdOffsets = 0x40;

std::vector<CanFrame> Read(const std::string& bytes, std::unique_ptr<FrameLog>& log, TempDir& dir) {
  WriteFile(dir.File("x.mf4"), bytes);
  log = OpenFrameLog(dir.File("x.mf4"));
  return ReadAll(*log);
}

// The layout of the first CANedge firmware (22-byte records: f64 ns time, then bit fields,
// DataBytes as a u64 VLSD offset), with error and remote frame groups and a VLSD group.
struct LoggerFile {
  Mf4Writer w;
  uint64_t dg = 0;
  std::string records;

  explicit LoggerFile(uint16_t unfinalised, uint64_t cycles = 0) : w(kStartNs, unfinalised) {
    const uint64_t ns = w.Conversion(1, {0, 1e-9});
    const uint64_t vlsd = w.Group(0, 0, 2, 0, 0, 1);
    const uint64_t data = w.Channels({{"Timestamp", 2, 4, 0, 0, 64, ns},
                                      {"CAN_DataFrame.BusChannel", 0, 0, 13, 2, 2},
                                      {"CAN_DataFrame.ID", 0, 0, 8, 3, 29},
                                      {"CAN_DataFrame.IDE", 0, 0, 8, 0, 1},
                                      {"CAN_DataFrame.DLC", 0, 0, 13, 4, 4},
                                      {"CAN_DataFrame.DataLength", 0, 0, 12, 1, 7},
                                      {"CAN_DataFrame.DataBytes", 1, 10, 14, 0, 64, 0, vlsd},
                                      {"CAN_DataFrame.EDL", 0, 0, 12, 0, 1},
                                      {"CAN_DataFrame.BRS", 0, 0, 13, 1, 1}});
    const uint64_t error = w.Channels({{"Timestamp", 2, 4, 0, 0, 64, ns}, {"CAN_ErrorFrame.BusChannel", 0, 0, 8, 0, 2}});
    const uint64_t remote = w.Channels({{"Timestamp", 2, 4, 0, 0, 64, ns},
                                        {"CAN_RemoteFrame.BusChannel", 0, 0, 8, 1, 2},
                                        {"CAN_RemoteFrame.ID", 0, 0, 8, 3, 29},
                                        {"CAN_RemoteFrame.IDE", 0, 0, 8, 0, 1},
                                        {"CAN_RemoteFrame.DLC", 0, 0, 13, 4, 4}});
    const uint64_t cg4 = w.Group(0, remote, 4, cycles, 14);
    const uint64_t cg3 = w.Group(cg4, error, 3, cycles, 9);
    w.SetLink(vlsd, 0, cg3);
    dg = w.DataGroup(w.Group(vlsd, data, 1, cycles, 22), 0, 1);
  }
  void Frame(double ns, uint8_t bus, uint32_t id, bool ext, bool fd, uint8_t dlc, uint8_t len, uint64_t offset) {
    std::string r(22, '\0');
    std::memcpy(r.data(), &ns, 8);
    Mf4Writer::Put(r, 13, 2, 2, bus);
    Mf4Writer::Put(r, 8, 3, 29, id);
    Mf4Writer::Put(r, 8, 0, 1, ext);
    Mf4Writer::Put(r, 13, 4, 4, dlc);
    Mf4Writer::Put(r, 12, 1, 7, len);
    Mf4Writer::Put(r, 14, 0, 64, offset);
    Mf4Writer::Put(r, 12, 0, 1, fd);
    Mf4Writer::Put(r, 13, 1, 1, fd);
    records += Le<uint8_t>(1) + r;
  }
  void Value(const std::string& bytes) { records += Le<uint8_t>(2) + Le<uint32_t>(static_cast<uint32_t>(bytes.size())) + bytes; }
  void Error(double ns, uint8_t bus) {
    std::string r(9, '\0');
    std::memcpy(r.data(), &ns, 8);
    Mf4Writer::Put(r, 8, 0, 2, bus);
    records += Le<uint8_t>(3) + r;
  }
  void Remote(double ns, uint32_t id, uint8_t dlc) {
    std::string r(14, '\0');
    std::memcpy(r.data(), &ns, 8);
    Mf4Writer::Put(r, 8, 3, 29, id);
    Mf4Writer::Put(r, 13, 4, 4, dlc);
    records += Le<uint8_t>(4) + r;
  }
  // The data block last in the file, its length field as an unfinalised file leaves it (24).
  std::string Finish(size_t cut = 0) {
    std::string dt = Mf4Writer::Block("##DT", {}, "");
    w.SetLink(dg, 2, w.Add(dt));
    return w.bytes() + records.substr(0, records.size() - cut);
  }
};

// Catches: an unfinalised file refused; its cycle counts of 0 or its DT length of 24 taken at
// their word (no frames); a VLSD value matched to the wrong frame (values after and before
// their frame records); the record cut by the power loss reported as damage.
TEST(Mf4Logger, UnfinalisedUnsortedFileIsReadToItsEnd) {
  TempDir dir;
  LoggerFile f(kCycles | kLastDt | kVlsdBytes);
  f.Frame(1e6, 1, 0x123, false, false, 3, 3, 0);  // its value follows
  f.Value("\x11\x22\x33");
  f.Value("ABCDEFGHIJKL");                        // a value before its frame (offset 7)
  f.Frame(2e6, 0, 0x1ABCDEF0, true, true, 9, 12, 7);
  f.Error(3e6, 2);
  f.Remote(4e6, 0x321, 4);
  f.Frame(5e6, 1, 0x124, false, false, 1, 1, 23);
  f.Value("\x42");
  f.Frame(6e6, 1, 0x125, false, false, 1, 1, 28);  // cut in the middle of this record
  std::unique_ptr<FrameLog> log;
  const auto fr = Read(f.Finish(10), log, dir);
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
  EXPECT_EQ(log->counters().malformed, 0u);
  ASSERT_EQ(fr.size(), 5u);
  EXPECT_EQ(fr[0].timestamp_ns, kStartNs + 1'000'000);
  EXPECT_EQ(fr[0].id, 0x123u);
  EXPECT_EQ(fr[0].len, 3);
  EXPECT_EQ(fr[0].data[2], 0x33);
  EXPECT_EQ(log->bus_names()[fr[0].bus], "can1");
  EXPECT_TRUE(fr[1].extended() && fr[1].fd() && (fr[1].flags & kFlagFdBrs));
  EXPECT_EQ(fr[1].len, 12);
  EXPECT_EQ(fr[1].data[11], 'L');
  EXPECT_TRUE(fr[2].error());
  EXPECT_EQ(log->bus_names()[fr[2].bus], "can2");
  EXPECT_TRUE(fr[3].remote());
  EXPECT_EQ(fr[3].len, 4);
  EXPECT_EQ(fr[3].id, 0x321u);
  EXPECT_EQ(fr[4].data[0], 0x42);
}

// Catches: the unfinalised rules applied to a file that says it is finalised (its cycle
// counts are the truth: a DT shorter than they say is a truncated file).
TEST(Mf4Logger, FinalisedFileWithShortDataIsTruncated) {
  TempDir dir;
  LoggerFile f(0, 2);
  f.Frame(1e6, 1, 0x123, false, false, 1, 1, 0);
  f.Value("A");
  std::string bytes = f.Finish();
  // A finalised file's DT states its length.
  const size_t dt = bytes.size() - f.records.size() - 24;
  const uint64_t length = 24 + f.records.size();
  std::memcpy(bytes.data() + dt + 8, &length, 8);
  std::unique_ptr<FrameLog> log;
  const auto fr = Read(bytes, log, dir);
  EXPECT_EQ(fr.size(), 1u);
  EXPECT_NE(log->io_error().find("1 of 2 records (truncated)"), std::string::npos) << log->io_error();
}

// Catches: a VLSD value that never comes delivered with stale bytes, or holding back the
// frames after it; with the offsets not written (flag 0x40), values matched by order.
TEST(Mf4Logger, VlsdValuesMissingOrMatchedByOrder) {
  TempDir dir;
  LoggerFile missing(kCycles | kLastDt);
  missing.Frame(1e6, 0, 0x100, false, false, 1, 1, 0);
  missing.Frame(2e6, 0, 0x101, false, false, 1, 1, 99);  // no value at offset 99
  missing.Value("A");
  std::unique_ptr<FrameLog> log;
  auto fr = Read(missing.Finish(), log, dir);
  ASSERT_EQ(fr.size(), 1u);
  EXPECT_EQ(fr[0].id, 0x100u);
  EXPECT_EQ(log->counters().malformed, 1u);
  ASSERT_FALSE(log->first_malformed().empty());
  EXPECT_NE(log->first_malformed()[0].reason.find("VLSD"), std::string::npos);
  LoggerFile by_order(kCycles | kLastDt | kVlsdOffsets);
  by_order.Frame(1e6, 0, 0x100, false, false, 1, 1, 0);
  by_order.Value("A");
  by_order.Frame(2e6, 0, 0x101, false, false, 1, 1, 0);
  by_order.Value("B");
  fr = Read(by_order.Finish(), log, dir);
  ASSERT_EQ(fr.size(), 2u) << log->io_error();
  EXPECT_EQ(fr[1].data[0], 'B');
}

// The layout of newer CANedge firmware: one group per frame kind, a 48-bit microsecond
// counter, BusChannel / IDE / EDL as virtual channels (constant conversions), DataLength a
// table of the DLC, DataBytes a 32-bit VLSD offset. Catches: virtual channels read from the
// record, conversions ignored (bus 0, standard ids, classic frames, length 9).
TEST(Mf4Logger, VirtualChannelsAndTableConversions) {
  TempDir dir;
  Mf4Writer w(kStartNs, kCycles | kLastDt);
  const uint64_t us = w.Conversion(1, {0, 1e-6}), nine = w.Conversion(1, {9, 0}), one = w.Conversion(1, {1, 0});
  std::vector<double> table;
  for (int dlc = 0; dlc < 16; ++dlc) {
    table.push_back(dlc);
    table.push_back(std::vector<double>{0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64}[static_cast<size_t>(dlc)]);
  }
  const uint64_t lengths = w.Conversion(5, table);
  const uint64_t vlsd = w.Group(0, 0, 45, 0, 0, 1);
  const uint64_t channels = w.Channels({{"Timestamp", 2, 0, 0, 0, 48, us},
                                        {"CAN_DataFrame.BusChannel", 6, 0, 0, 0, 0, nine},
                                        {"CAN_DataFrame.ID", 0, 0, 6, 0, 29},
                                        {"CAN_DataFrame.IDE", 6, 0, 0, 0, 0, one},
                                        {"CAN_DataFrame.DLC", 0, 0, 10, 0, 4},
                                        {"CAN_DataFrame.DataLength", 0, 0, 10, 0, 4, lengths},
                                        {"CAN_DataFrame.DataBytes", 1, 10, 11, 0, 32, 0, vlsd},
                                        {"CAN_DataFrame.EDL", 6, 0, 0, 0, 0, one},
                                        {"CAN_DataFrame.ESI", 0, 0, 10, 7, 1},
                                        {"CAN_DataFrame.BRS", 0, 0, 10, 6, 1}});
  const uint64_t dg = w.DataGroup(w.Group(vlsd, channels, 44, 0, 15), 0, 1);
  std::string records;
  for (uint32_t i = 0; i < 3; ++i) {
    std::string r(15, '\0');
    Mf4Writer::Put(r, 0, 0, 48, 16'701'700 + i);
    Mf4Writer::Put(r, 6, 0, 29, 0x18F00E00 + i);
    Mf4Writer::Put(r, 10, 0, 4, 9);
    Mf4Writer::Put(r, 10, 6, 1, 1);
    Mf4Writer::Put(r, 11, 0, 32, 16 * i);
    records += Le<uint8_t>(44) + r + Le<uint8_t>(45) + Le<uint32_t>(12) + std::string(12, static_cast<char>('a' + i));
  }
  w.SetLink(dg, 2, w.Add(Mf4Writer::Block("##DT", {}, "")));
  std::unique_ptr<FrameLog> log;
  const auto fr = Read(w.bytes() + records, log, dir);
  ASSERT_EQ(fr.size(), 3u) << log->io_error();
  EXPECT_EQ(fr[2].timestamp_ns, kStartNs + 16'701'702'000);
  EXPECT_EQ(log->bus_names()[fr[2].bus], "can9");
  EXPECT_TRUE(fr[2].extended() && fr[2].fd() && (fr[2].flags & kFlagFdBrs));
  EXPECT_EQ(fr[2].id, 0x18F00E02u);
  EXPECT_EQ(fr[2].len, 12);
  EXPECT_EQ(fr[2].data[11], 'c');
}

// A finalised sorted file as a logger's converter leaves it: DataBytes in signal data (SD)
// blocks, data and signal data deflated (DZ). Catches: SD / DZ(SD) not read; offsets into the
// signal data misread.
TEST(Mf4Logger, SortedFileWithDeflatedDataAndSignalData) {
  TempDir dir;
  LoggerFile f(0, 3);
  std::string values;
  for (int i = 0; i < 3; ++i) {
    f.Frame(1e6 * (i + 1), 0, 0x200 + i, false, false, 2, 2, values.size());
    values += Le<uint32_t>(2) + std::string(2, static_cast<char>('x' + i));
  }
  // Keep the CAN_DataFrame group only, sorted: its records without record ids, DataBytes -> SD.
  std::string data;
  for (size_t at = 0; at < f.records.size(); at += 23) data += f.records.substr(at + 1, 22);
  std::string& b = f.w.bytes();
  const uint64_t sd = f.w.Add(Mf4Writer::Dz("SD", values));
  const uint64_t dz = f.w.Add(Mf4Writer::Dz("DT", data));
  f.w.SetLink(f.dg, 2, dz);
  b[f.dg + 24 + 4 * 8] = 0;  // record id size 0: sorted
  uint64_t cg = 0;
  std::memcpy(&cg, b.data() + f.dg + 24 + 8, 8);
  f.w.SetLink(cg, 0, 0);  // no other group in this data group
  f.w.SetLink(b.find("##CN", b.find("CAN_DataFrame.DataBytes")), 5, sd);  // the CN block follows its name
  std::unique_ptr<FrameLog> log;
  const auto fr = Read(b, log, dir);
  ASSERT_EQ(fr.size(), 3u) << log->io_error();
  EXPECT_EQ(fr[2].id, 0x202u);
  EXPECT_EQ(fr[2].data[1], 'z');
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
}

// Catches: the last DL's links that were not written (flag 0x10) left empty: the data blocks
// after the list are its blocks, the last of them open to the end of the file.
TEST(Mf4Logger, LastDataListLinksNotWritten) {
  TempDir dir;
  LoggerFile f(kCycles | kLastDt | kLastDl);
  f.Frame(1e6, 0, 0x300, false, false, 1, 1, 0);
  f.Value("A");
  const std::string first = f.records;
  f.records.clear();
  f.Frame(2e6, 0, 0x301, false, false, 1, 1, 5);
  f.Value("B");
  const uint64_t dt1 = f.w.Add(Mf4Writer::Block("##DT", {}, first));
  const uint64_t dl = f.w.Add(Mf4Writer::Block("##DL", {0, dt1, 0, 0}, Le<uint8_t>(0) + std::string(3, '\0') + Le<uint32_t>(3)));
  f.w.SetLink(f.dg, 2, dl);
  f.w.Add(Mf4Writer::Block("##DT", {}, ""));
  std::unique_ptr<FrameLog> log;
  const auto fr = Read(f.w.bytes() + f.records, log, dir);
  ASSERT_EQ(fr.size(), 2u) << log->io_error();
  EXPECT_EQ(fr[1].id, 0x301u);
  EXPECT_EQ(fr[1].data[0], 'B');
}

}  // namespace
}  // namespace ndsid::can
