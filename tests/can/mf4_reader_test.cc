// The MF4 bus-logging reader on files written by asammdf (through python-can's MF4Writer;
// the seeds in tests/fuzz/corpus/mf4, made by tests/fuzz/make_log_corpus.py from the first 60
// frames of replay/clean/drive.log.gz plus remote, error, CAN FD and second-bus frames):
// plain DT and transposed-deflate DZ data, three data groups merged in time order; and the
// ways a file can be short.
#include <gtest/gtest.h>

#include <cstring>

#include "log_test_util.h"
#include "mf4_test_util.h"
#include "ndsid/can/candump_reader.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"

namespace ndsid::can {
namespace {

using namespace testing;  // NOLINT

const std::string kCorpus = std::string(NDSID_SOURCE_DIR) + "/tests/fuzz/corpus/mf4/";

std::vector<CanFrame> FirstDriveFrames(size_t n) {
  CandumpReader reader(std::string(NDSID_SOURCE_DIR) + "/replay/clean/drive.log.gz");
  std::vector<CanFrame> frames(n);
  size_t got = 0;
  while (got < n) got += reader.Read(std::span<CanFrame>(frames).subspan(got), 0).count;
  return frames;
}

void ExpectSameAsDriveLog(const std::string& file) {
  SCOPED_TRACE(file);
  auto log = OpenFrameLog(kCorpus + file);
  ASSERT_EQ(log->format(), LogFormat::kMf4);
  const auto all = ReadAll(*log);
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
  EXPECT_EQ(log->counters().malformed, 0u);
  ASSERT_EQ(all.size(), 65u);
  std::vector<CanFrame> plain;
  int remote = 0, error = 0, fd = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    const CanFrame& f = all[i];
    if (i > 0) {
      EXPECT_GE(f.timestamp_ns, all[i - 1].timestamp_ns) << "merged in time order at " << i;
    }
    remote += f.remote();
    error += f.error();
    fd += f.fd();
    if (!f.remote() && !f.error() && !f.fd() && log->bus_names()[f.bus] == "can0") plain.push_back(f);
  }
  EXPECT_EQ(remote, 1);
  EXPECT_EQ(error, 1);
  EXPECT_EQ(fd, 2);
  const auto want = FirstDriveFrames(60);
  ASSERT_EQ(plain.size(), 60u);  // the 60 drive frames, plus one classic frame on can1
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(plain[i].id, want[i].id) << i;
    EXPECT_EQ(plain[i].extended(), want[i].extended()) << i;
    ASSERT_EQ(plain[i].len, want[i].len) << i;
    EXPECT_EQ(0, std::memcmp(plain[i].data.data(), want[i].data.data(), want[i].len)) << i;
    // the corpus re-based the times to a whole millisecond; differences are kept to the
    // writer's precision: python-can hands asammdf float64 epoch seconds (ulp 240 ns)
    const int64_t got_dt = plain[i].timestamp_ns - plain[0].timestamp_ns;
    const int64_t want_dt = want[i].timestamp_ns - want[0].timestamp_ns;
    EXPECT_NEAR(static_cast<double>(got_dt), static_cast<double>(want_dt), 500.0) << i;
  }
}

TEST(Mf4Reader, PlainDataBlocksEqualTheCandumpOriginal) { ExpectSameAsDriveLog("asammdf_dt.mf4"); }

TEST(Mf4Reader, TransposedDeflateBlocksEqualTheCandumpOriginal) { ExpectSameAsDriveLog("asammdf_dz.mf4"); }

// Patches the cycle count of every non-empty channel group: the data then ends early, as in a
// file whose trailing data block was cut off.
TEST(Mf4Reader, FewerRecordsThanTheGroupDeclaresIsReportedAsTruncated) {
  TempDir dir;
  std::string bytes = ReadFile(kCorpus + "asammdf_dt.mf4");
  int patched = 0;
  for (size_t at = bytes.find("##CG"); at != std::string::npos; at = bytes.find("##CG", at + 4)) {
    uint64_t links = 0, cycles = 0;
    std::memcpy(&links, bytes.data() + at + 16, 8);
    const size_t cycles_at = at + 24 + 8 * links + 8;
    std::memcpy(&cycles, bytes.data() + cycles_at, 8);
    if (cycles == 0) continue;
    cycles += 5;
    std::memcpy(bytes.data() + cycles_at, &cycles, 8);
    ++patched;
  }
  ASSERT_GT(patched, 0);
  WriteFile(dir.File("short.mf4"), bytes);
  auto log = OpenFrameLog(dir.File("short.mf4"));
  ReadAll(*log);
  EXPECT_NE(log->io_error().find("truncated"), std::string::npos) << log->io_error();
}

TEST(Mf4Reader, FileCutBeforeItsMetadataCannotBeOpened) {
  TempDir dir;
  const std::string bytes = ReadFile(kCorpus + "asammdf_dz.mf4");
  WriteFile(dir.File("cut.mf4"), bytes.substr(0, bytes.size() / 2));
  try {
    auto log = OpenFrameLog(dir.File("cut.mf4"));
    ReadAll(*log);
    EXPECT_FALSE(log->io_error().empty()) << "a cut file read as complete";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(dir.File("cut.mf4")), std::string::npos) << e.what();
  }
}

// Found by the mf4 fuzz target (a timeout, tests/fuzz/regressions/mf4/timeout-c987...): a data
// group list whose next link points back made the reader walk it up to its count limit,
// 100 000 copies of the same group, each read in full. Every DG, CG and CN block belongs to one
// list, so a link back is refused with the byte it points at.
TEST(Mf4Reader, AListThatLinksBackIsRefusedNotReadAgain) {
  TempDir dir;
  std::string bytes = ReadFile(kCorpus + "asammdf_dt.mf4");
  uint64_t dg = 0;
  std::memcpy(&dg, bytes.data() + 64 + 24, 8);  // HD's first link: the first data group
  ASSERT_GT(dg, 64u);
  std::memcpy(bytes.data() + dg + 24, &dg, 8);  // the group's next-DG link: itself
  WriteFile(dir.File("loop.mf4"), bytes);
  try {
    OpenFrameLog(dir.File("loop.mf4"));
    ADD_FAILURE() << "a looping data group list was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("loops back to byte " + std::to_string(dg)), std::string::npos) << e.what();
  }
  // The fuzzer's input: refused at once, not after minutes.
  const std::string found = std::string(NDSID_SOURCE_DIR) + "/tests/fuzz/regressions/mf4/timeout-c987855db25bcad9209264492afe79d891eedfeb";
  EXPECT_THROW(OpenFrameLog(found), Error);
}

// Found by the mf4 fuzz target (slow units, tests/fuzz/regressions/mf4/slow-dz-columns-beyond-data):
// a transposed DZ block declaring more columns than it has bytes (2^32 - 1 for 84) has no row to
// transpose, but the reader looped over every empty column: seconds per 70-byte input under
// ASan. Such a block is now kept as stored, which for one row is what the transposition gives:
// the file reads frame for frame like the original, whose two small blocks have exactly one row.
TEST(Mf4Reader, TransposedBlockWithMoreColumnsThanBytesReadsAsStored) {
  const std::string found = std::string(NDSID_SOURCE_DIR) + "/tests/fuzz/regressions/mf4/slow-dz-columns-beyond-data";
  auto original = OpenFrameLog(kCorpus + "asammdf_dz.mf4");
  auto changed = OpenFrameLog(found);
  const auto want = ReadAll(*original);
  const auto got = ReadAll(*changed);
  EXPECT_TRUE(changed->io_error().empty()) << changed->io_error();
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(got[i].id, want[i].id) << i;
    EXPECT_EQ(got[i].timestamp_ns, want[i].timestamp_ns) << i;
    ASSERT_EQ(got[i].len, want[i].len) << i;
    EXPECT_EQ(0, std::memcmp(got[i].data.data(), want[i].data.data(), want[i].len)) << i;
  }
}

TEST(Mf4Reader, FileWithoutBusLoggingSaysSo) {
  TempDir dir;
  // ID block + an HD block without data groups: an MF4 file, but not bus logging.
  std::string f = "MDF     4.10    ndsid   " + std::string(4, '\0') + Le<uint16_t>(410);
  f.resize(64, '\0');
  f += "##HD" + std::string(4, '\0') + Le<uint64_t>(24 + 6 * 8 + 32) + Le<uint64_t>(6) + std::string(6 * 8 + 32, '\0');
  WriteFile(dir.File("signals.mf4"), f);
  try {
    OpenFrameLog(dir.File("signals.mf4"));
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("CAN bus-logging"), std::string::npos) << e.what();
  }
}

// A hand-made unsorted MF4 (record ids of 1 byte): a CAN_DataFrame group (record id 1) whose
// time master is a uint64 count of microseconds with a linear conversion, interleaved with a
// decoded-signal group (record id 2) that must be skipped; the data block is last in the file.
class UnsortedMf4 {
 public:
  static constexpr int64_t kStartNs = 1700000000'000'000'000LL;

  std::string Build() {
    Mf4Writer w(kStartNs);
    const uint64_t cc = w.Conversion(1, {0.5, 1e-6});
    const uint64_t can_channels = w.Channels({{"t", 2, 0, 0, 0, 64, cc},
                                              {"CAN_DataFrame.BusChannel", 0, 0, 8, 0, 8},
                                              {"CAN_DataFrame.ID", 0, 0, 9, 0, 32},
                                              {"CAN_DataFrame.IDE", 0, 0, 13, 0, 8},
                                              {"CAN_DataFrame.DLC", 0, 0, 14, 0, 8},
                                              {"CAN_DataFrame.DataLength", 0, 0, 15, 0, 8},
                                              {"CAN_DataFrame.DataBytes", 0, 10, 16, 0, 64}});
    const uint64_t other_channels = w.Channels({{"t", 2, 4, 0, 0, 64}, {"EngineSpeed", 0, 0, 8, 0, 16}});
    const uint64_t cg2 = w.Group(0, other_channels, 2, 2, 10);
    const uint64_t cg1 = w.Group(cg2, can_channels, 1, 3, 24);
    const uint64_t dg = w.DataGroup(cg1, 0, 1);
    std::string records;
    records += Frame(1000, 1, 0x123, false, "\x11\x22\x33");
    records += Other(1500.0, 4000);
    records += Frame(2000, 0, 0x1ABCDEF0, true, "\x01\x02\x03\x04\x05\x06\x07\x08");
    records += Other(2500.0, 4100);
    records += Frame(3000, 1, 0x7FF, false, "");
    w.SetLink(dg, 2, w.Add(Mf4Writer::Block("##DT", {}, records)));  // the data block is last in the file
    return w.bytes();
  }

 private:
  static std::string Frame(uint64_t time_us, uint8_t bus, uint32_t id, bool ext, const std::string& data) {
    std::string d = data;
    d.resize(8, '\0');
    return Le<uint8_t>(1) + Le(time_us) + Le(bus) + Le(id) + Le<uint8_t>(ext) + Le<uint8_t>(static_cast<uint8_t>(data.size())) +
           Le<uint8_t>(static_cast<uint8_t>(data.size())) + d;
  }
  static std::string Other(double time_s, uint16_t value) { return Le<uint8_t>(2) + F64(time_s) + Le(value); }
};

TEST(Mf4Reader, UnsortedGroupsWithLinearTimeConversion) {
  TempDir dir;
  const std::string file = UnsortedMf4().Build();
  WriteFile(dir.File("u.mf4"), file);
  auto log = OpenFrameLog(dir.File("u.mf4"));
  const auto f = ReadAll(*log);
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(log->skipped_records(), 2u);  // the decoded-signal records
  // time = start + (0.5 s + 1e-6 * raw)
  EXPECT_EQ(f[0].timestamp_ns, UnsortedMf4::kStartNs + 500'000'000 + 1'000'000);
  EXPECT_EQ(f[0].id, 0x123u);
  EXPECT_EQ(f[0].len, 3);
  EXPECT_EQ(f[0].data[2], 0x33);
  EXPECT_EQ(log->bus_names()[f[0].bus], "can1");
  EXPECT_EQ(f[1].id, 0x1ABCDEF0u);
  EXPECT_TRUE(f[1].extended());
  EXPECT_EQ(f[1].data[7], 8);
  EXPECT_EQ(log->bus_names()[f[1].bus], "can0");
  EXPECT_EQ(f[2].timestamp_ns, UnsortedMf4::kStartNs + 500'000'000 + 3'000'000);
  EXPECT_EQ(f[2].len, 0);
  // The same file cut in the middle of its (last) data block: two frames, then "truncated".
  WriteFile(dir.File("cut.mf4"), file.substr(0, file.size() - 30));
  auto cut = OpenFrameLog(dir.File("cut.mf4"));
  EXPECT_EQ(ReadAll(*cut).size(), 2u);
  EXPECT_NE(cut->io_error().find("truncated"), std::string::npos) << cut->io_error();
}

}  // namespace
}  // namespace ndsid::can
