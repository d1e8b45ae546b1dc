// The MF4 bus-logging reader on files written by asammdf (through python-can's MF4Writer;
// the seeds in tests/fuzz/corpus/mf4, made by tests/fuzz/make_log_corpus.py from the first 60
// frames of replay/clean/drive.log.gz plus remote, error, CAN FD and second-bus frames):
// plain DT and transposed-deflate DZ data, three data groups merged in time order; and the
// ways a file can be short.
#include <gtest/gtest.h>

#include <cstring>

#include "log_test_util.h"
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

}  // namespace
}  // namespace ndsid::can
