// The BLF reader on hand-built records of every layout Vector's tools write: object header
// versions 1 and 2, time stamps in 10 us and in ns (also beyond the 5 days that once made every
// ns object "out of range"), the file's start time, CAN_ERROR / CAN_ERROR_EXT / CAN_FD_ERROR_64,
// channel numbers beyond 256, objects split over several containers, one container far larger
// than the reader's buffers, a GLOBAL_MARKER longer than its size field; and the errors: a record that cannot be placed in time (with its
// place), a file of mostly such records (an error, not "0 frames"), a CAN object outside a
// container (python-can and vector_blf read none).
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "log_test_util.h"
#include "ndsid/can/frame_log.h"

namespace ndsid::can {
namespace {

using namespace testing;  // NOLINT

constexpr uint32_t kCanMessage = 1, kCanError = 2, kCanErrorExt = 73, kCanMessage2 = 86, kCanFdMessage = 100,
                   kCanFdMessage64 = 101, kCanFdError64 = 104;

std::vector<CanFrame> ReadBlf(const std::string& bytes, std::unique_ptr<FrameLog>& log, TempDir& dir) {
  WriteFile(dir.File("x.blf"), bytes);
  log = OpenFrameLog(dir.File("x.blf"));
  return ReadAll(*log);
}

// CAN_FD_MESSAGE body: channel, flags, dlc, id, frame length, bit count, FD flags, valid bytes, data[64].
std::string FdBody(uint16_t channel, uint8_t dlc, uint32_t id, uint8_t fd_flags, const std::string& data) {
  std::string d = data;
  d.resize(64, '\0');
  return Le(channel) + Le<uint8_t>(0) + Le(dlc) + Le(id) + Le<uint32_t>(0) + Le<uint8_t>(0) + Le(fd_flags) +
         Le<uint8_t>(static_cast<uint8_t>(data.size())) + std::string(5, '\0') + d;
}

// Catches: the header version 2 (40 bytes) read as version 1 (body 8 bytes early); 10 us units
// taken as ns or the reverse; the start time of the file header left out.
TEST(BlfReader, HeaderVersionTwoAndBothTimeUnits) {
  TempDir dir;
  std::string inner = BlfObjectV2(kCanMessage, 150, BlfCanBody(1, 0, 2, 0x101, "\x01\x02"), 1);  // 150 x 10 us
  inner += BlfObjectV2(kCanMessage2, 2'000'123, BlfCanBody(2, 0, 1, 0x102, "\x03") + std::string(8, '\0'), 2);
  inner += BlfObject(kCanMessage, 400, BlfCanBody(1, 0, 1, 0x103, "\x04"), 1);
  inner += BlfObject(kCanFdMessage, 5'000'000, FdBody(1, 9, 0x80000104u, 0x3, std::string(12, '\x05')), 2);
  std::unique_ptr<FrameLog> log;
  const auto f = ReadBlf(BlfFile(BlfContainer(inner)), log, dir);
  ASSERT_EQ(f.size(), 4u) << log->io_error();
  EXPECT_EQ(f[0].timestamp_ns, kBlfStartNs + 1'500'000);
  EXPECT_EQ(f[0].id, 0x101u);
  EXPECT_EQ(f[0].data[1], 2);
  EXPECT_EQ(f[1].timestamp_ns, kBlfStartNs + 2'000'123);
  EXPECT_EQ(f[1].id, 0x102u);
  EXPECT_EQ(log->bus_names()[f[1].bus], "can1");
  EXPECT_EQ(f[2].timestamp_ns, kBlfStartNs + 4'000'000);
  EXPECT_TRUE(f[3].fd() && f[3].extended() && (f[3].flags & kFlagFdBrs));
  EXPECT_EQ(f[3].len, 12);
  EXPECT_EQ(log->counters().malformed, 0u);
}

// vector_blf's and python-can's test files: no start time, object times of 2.46e18 ns (77
// years). Catches: a range check in 10 us units applied to ns times (the cause of "object time
// out of range" on every ns object after 5.3 days).
TEST(BlfReader, NanosecondTimesOfAnySizeWithoutAStartTime) {
  TempDir dir;
  std::string file = BlfFile(BlfContainer(BlfObject(kCanMessage, 2459565876494606882ull, BlfCanBody(1, 0, 1, 0x7FF, "A"))));
  std::fill(file.begin() + 40, file.begin() + 56, '\0');  // SYSTEMTIME start all zero: none
  std::unique_ptr<FrameLog> log;
  const auto f = ReadBlf(file, log, dir);
  ASSERT_EQ(f.size(), 1u) << log->io_error();
  EXPECT_EQ(f[0].timestamp_ns, 2459565876494606882ll);
}

// Catches: an object whose time overflows int64 ns delivered with a wrapped time, or dropped
// without its place; a file of nothing but such objects taken as an empty log.
TEST(BlfReader, RecordsThatCannotBePlacedInTimeAreLocatedAndAFileOfThemIsAnError) {
  TempDir dir;
  const uint64_t too_late = uint64_t{1} << 62;  // x 10 us: beyond int64 ns
  std::string inner = BlfObject(kCanMessage, 10, BlfCanBody(1, 0, 1, 0x100, "A"), 2);
  inner += BlfObject(kCanMessage, too_late, BlfCanBody(1, 0, 1, 0x101, "B"), 1);
  inner += BlfObject(kCanMessage, 30, BlfCanBody(1, 0, 1, 0x102, "C"), 2);
  std::unique_ptr<FrameLog> log;
  auto f = ReadBlf(BlfFile(BlfContainer(inner)), log, dir);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();  // one bad record of three: read on
  ASSERT_EQ(log->first_malformed().size(), 1u);
  EXPECT_EQ(log->Locate(log->first_malformed()[0]),
            dir.File("x.blf") + ": byte 144: object at byte 48 of the log container's data: object time stamp out of "
                                "range (cannot be placed in time)");
  // Two of three bad: the file is an error that names the first bad record.
  inner = BlfObject(kCanMessage, too_late, BlfCanBody(1, 0, 1, 0x100, "A"), 1);
  inner += BlfObject(kCanMessage, too_late, BlfCanBody(1, 0, 1, 0x101, "B"), 1);
  inner += BlfObject(kCanMessage, 30, BlfCanBody(1, 0, 1, 0x102, "C"), 2);
  f = ReadBlf(BlfFile(BlfContainer(inner)), log, dir);
  EXPECT_EQ(f.size(), 1u);
  EXPECT_NE(log->io_error().find("2 of 3 CAN records are malformed"), std::string::npos) << log->io_error();
  EXPECT_NE(log->io_error().find("byte 144: object at byte 0"), std::string::npos) << log->io_error();
}

// Catches: CAN_ERROR and CAN_FD_ERROR_64 skipped (python-can skips them; they are bus errors
// all the same), a channel read from the wrong byte of CAN_FD_ERROR_64 (u8, not u16), channels
// above 256 refused.
TEST(BlfReader, ErrorObjectsOfEveryKindAndLargeChannelNumbers) {
  TempDir dir;
  std::string inner = BlfObject(kCanError, 10, Le<uint16_t>(2) + Le<uint16_t>(0) + Le<uint32_t>(0));
  inner += BlfObject(kCanErrorExt, 20, Le<uint16_t>(3) + std::string(30, '\0'));
  inner += BlfObject(kCanFdError64, 30, Le<uint8_t>(4) + Le<uint8_t>(9) + std::string(78, '\0'));
  inner += BlfObject(kCanMessage, 40, BlfCanBody(0x1111, 0, 1, 0x100, "A"));
  std::unique_ptr<FrameLog> log;
  const auto f = ReadBlf(BlfFile(BlfContainer(inner)), log, dir);
  ASSERT_EQ(f.size(), 4u) << log->io_error();
  for (int i = 0; i < 3; ++i) {
    EXPECT_TRUE(f[i].error()) << i;
    EXPECT_EQ(log->bus_names()[f[i].bus], "can" + std::to_string(i + 1)) << i;
  }
  EXPECT_EQ(log->counters().error_frames, 3u);
  EXPECT_EQ(log->bus_names()[f[3].bus], "can4368");
}

// Catches: an object cut by container boundaries more than once (a CAN_FD_MESSAGE_64 of 104
// bytes over containers of 30 bytes) not joined; a stored container between zlib ones.
TEST(BlfReader, AnObjectSplitOverManyContainersIsJoined) {
  TempDir dir;
  std::string data(64, '\0');
  for (int i = 0; i < 64; ++i) data[static_cast<size_t>(i)] = static_cast<char>(i + 1);
  const std::string fd64 = Le<uint8_t>(2) + Le<uint8_t>(15) + Le<uint8_t>(64) + Le<uint8_t>(0) + Le<uint32_t>(0x7FEu) +
                           Le<uint32_t>(0) + Le<uint32_t>(0x1000) + std::string(16, '\0') + Le<uint16_t>(0) +
                           Le<uint8_t>(0) + Le<uint8_t>(0) + Le<uint32_t>(0) + data;
  const std::string inner = BlfObject(kCanFdMessage64, 7, fd64) + BlfObject(kCanMessage, 8, BlfCanBody(1, 0, 1, 0x5, "Z"));
  std::string containers;
  for (size_t at = 0, n = 0; at < inner.size(); at += 30, ++n) containers += BlfContainer(inner.substr(at, 30), n % 2 == 0);
  std::unique_ptr<FrameLog> log;
  const auto f = ReadBlf(BlfFile(containers), log, dir);
  ASSERT_EQ(f.size(), 2u) << log->io_error();
  EXPECT_TRUE(f[0].fd());
  EXPECT_EQ(f[0].len, 64);
  EXPECT_EQ(f[0].data[63], 64);
  EXPECT_EQ(log->bus_names()[f[0].bus], "can1");
  EXPECT_EQ(f[1].id, 0x5u);
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
}

// vector_blf's events_from_converter/test_GlobalMarker.blf (Vector CANape): a GLOBAL_MARKER
// whose size field leaves out its three strings. Catches: the strings taken for a damaged
// object stream (malformed records, a file of markers made an error).
TEST(BlfReader, GlobalMarkerStringsBeyondItsSizeField) {
  TempDir dir;
  const std::string fixed = std::string(16, '\0') + Le<uint32_t>(4) + Le<uint32_t>(4) + Le<uint32_t>(8) + std::string(12, '\0');
  std::string marker = BlfObject(96, 5, fixed);  // size 72: without the strings
  marker += std::string("grp\0mrk\0descript", 16);
  const std::string inner = marker + BlfObject(kCanMessage, 9, BlfCanBody(1, 0, 1, 0x7, "M"));
  std::unique_ptr<FrameLog> log;
  const auto f = ReadBlf(BlfFile(BlfContainer(inner)), log, dir);
  ASSERT_EQ(f.size(), 1u) << log->io_error();
  EXPECT_EQ(f[0].id, 0x7u);
  EXPECT_EQ(log->counters().malformed, 0u);
  EXPECT_EQ(log->skipped_records(), 1u);
}

uint64_t ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
}

// One container of 48 MiB (a million CAN messages; Vector writes 128 KiB ones) read in pieces.
// Catches: a container size limit; the whole container inflated at once (memory).
TEST(BlfReader, AContainerOfAnySizeIsStreamed) {
  TempDir dir;
  const int kFrames = 1'000'000;
  std::string inner;
  inner.reserve(static_cast<size_t>(kFrames) * 48);
  for (int i = 0; i < kFrames; ++i) inner += BlfObject(kCanMessage, 1000u * i, BlfCanBody(1, 0, 1, i & 0x7FF, "Q"));
  WriteFile(dir.File("x.blf"), BlfFile(BlfContainer(inner)));
  inner.clear();
  inner.shrink_to_fit();
  auto log = OpenFrameLog(dir.File("x.blf"));
  const uint64_t before = ResidentBytes();
  std::vector<CanFrame> buf(1024);
  uint64_t frames = 0, peak = before;
  for (;;) {
    const ReadResult r = log->Read(buf, 0);
    if (r.state == SourceState::kEnd) break;
    frames += r.count;
    if (frames % (64 * 1024) < 1024) peak = std::max(peak, ResidentBytes());
  }
  EXPECT_EQ(frames, static_cast<uint64_t>(kFrames));
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
  EXPECT_LT(peak - before, uint64_t{8} << 20) << "resident set grew while reading one 48 MiB container";
}

// Catches: CAN objects outside any container delivered (python-can and vector_blf read none;
// vector_blf's FileWithoutLogContainers.blf) or dropped silently.
TEST(BlfReader, CanObjectsOutsideContainersAreRejected) {
  TempDir dir;
  const std::string loose = BlfObject(kCanMessage, 10, BlfCanBody(1, 0, 1, 0x100, "A")) +
                            BlfObject(kCanMessage, 20, BlfCanBody(1, 0, 1, 0x101, "B"));
  std::unique_ptr<FrameLog> log;
  const auto f = ReadBlf(BlfFile(loose), log, dir);
  EXPECT_TRUE(f.empty());
  EXPECT_EQ(log->counters().malformed, 2u);
  EXPECT_NE(log->io_error().find("outside a log container"), std::string::npos) << log->io_error();
}

}  // namespace
}  // namespace ndsid::can
