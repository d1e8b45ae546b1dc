// OpenFrameLog: the format comes from the content (not the name), unsupported files say what
// they look like, and the ASC and BLF readers on hand-made files: every frame kind, exact
// times, malformed records counted with their place, truncated files reported.
#include <gtest/gtest.h>

#include "log_test_util.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"

namespace ndsid::can {
namespace {

using namespace testing;  // NOLINT

constexpr const char* kCandump = "(1700000000.000100) can0 123#DEADBEEF\n(1700000000.000200) can1 18FEF100#01\n";

constexpr const char* kAsc =
    "date Mon Mar 4 07:30:00.000 am 2024\n"
    "base hex  timestamps absolute\n"
    "internal events logged\n"
    "// version 9.0.0\n"
    "Begin Triggerblock Mon Mar 4 07:30:00.250 2024\n"
    "   0.000000 Start of measurement\n"
    "   0.001000 1  123             Rx   d 4 DE AD BE EF  Length = 108000 BitCount = 56 ID = 291\n"
    "   0.002500 2  1ABCDEF0x       Tx   d 8 01 02 03 04 05 06 07 08\n"
    "   0.003000 1  321             Rx   r 2\n"
    "   0.004000 1  ErrorFrame\n"
    "   0.005000 1  Statistic: D 0 R 0 XD 0 XR 0 E 0 O 0 B 0.00%\n"
    "   0.006000 CANFD   3 Rx        7FF                                   1 0 9 12 00 01 02 03 04 05 06 07 08 09 0A 0B        0    0     3000        0        0        0        0        0\n"
    "   0.007000 1  123             Rx   d 2 0G 01\n"
    "this line means nothing\n"
    "   0.008000 1  124             Rx   d 1 42\n"
    "End TriggerBlock\n";

TEST(FrameLog, RecognisesTheFormatFromTheContentNotTheName) {
  TempDir dir;
  WriteFile(dir.File("really_candump.blf"), kCandump);
  WriteFile(dir.File("really_asc.log"), kAsc);
  WriteGzip(dir.File("asc_in_gzip.txt"), kAsc);
  const std::string blf = BlfFile(BlfContainer(BlfObject(1, 0, BlfCanBody(1, 0, 1, 0x10, "A"))));
  WriteFile(dir.File("really_blf.asc"), blf);
  WriteFile(dir.File("empty"), "");
  EXPECT_EQ(DetectLogFormat(dir.File("really_candump.blf")), LogFormat::kCandump);
  EXPECT_EQ(DetectLogFormat(dir.File("really_asc.log")), LogFormat::kAsc);
  EXPECT_EQ(DetectLogFormat(dir.File("asc_in_gzip.txt")), LogFormat::kAsc);
  EXPECT_EQ(DetectLogFormat(dir.File("really_blf.asc")), LogFormat::kBlf);
  EXPECT_EQ(DetectLogFormat(dir.File("empty")), LogFormat::kCandump);
  auto asc = OpenFrameLog(dir.File("asc_in_gzip.txt"));
  EXPECT_EQ(ReadAll(*asc).size(), 6u);
  EXPECT_NE(asc->Describe().find("gzip"), std::string::npos);
  auto candump = OpenFrameLog(dir.File("really_candump.blf"));
  EXPECT_EQ(ReadAll(*candump).size(), 2u);
  EXPECT_THROW(OpenFrameLog(dir.File("missing")), Error);
}

// Each unsupported file: ConfigError naming the file and what it looks like.
TEST(FrameLog, UnsupportedFilesSayWhatTheyLookLikeAndWhatToDo) {
  TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {std::string("\xd4\xc3\xb2\xa1\x02\x00\x04\x00", 8) + std::string(40, '\0'), "pcap capture"},
      {"t,id,data\n0.001,123,DEADBEEF\n0.002,124,00\n", "CSV"},
      {std::string("\x01\x02\x00\x00\x07\x00\xff\xfe", 8) + std::string(100, '\0'), "unknown binary"},
      {";$FILEVERSION=1.1\n;$STARTTIME=45000.1\n", "PEAK PCAN trace"},
      {"MDF     3.30    TGT 15.0" + std::string(40, '\0'), "MDF 3"},
      {"  can0  123   [4]  DE AD BE EF\n  can0  124   [1]  00\n", "candump screen output"},
      {"hello world\nthis is prose\n", "unknown format"},
  };
  int i = 0;
  for (const auto& [bytes, kind] : cases) {
    const std::string path = dir.File("case" + std::to_string(i++));
    WriteFile(path, bytes);
    try {
      OpenFrameLog(path);
      ADD_FAILURE() << kind << ": accepted";
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find(kind), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << "one line: " << what;
    }
  }
  // MF4 inside gzip: named, with the fix.
  WriteGzip(dir.File("x.mf4.gz"), "MDF     4.10    " + std::string(48, '\0'));
  EXPECT_THROW(
      {
        try {
          OpenFrameLog(dir.File("x.mf4.gz"));
        } catch (const ConfigError& e) {
          EXPECT_NE(std::string(e.what()).find("gunzip"), std::string::npos) << e.what();
          throw;
        }
      },
      ConfigError);
}

TEST(AscReader, ReadsEveryFrameKindWithTimesFromTheTriggerBlockDate) {
  TempDir dir;
  WriteFile(dir.File("a.asc"), kAsc);
  auto log = OpenFrameLog(dir.File("a.asc"));
  ASSERT_EQ(log->format(), LogFormat::kAsc);
  const auto frames = ReadAll(*log);
  ASSERT_EQ(frames.size(), 6u);
  const int64_t start = 1709537400'250'000'000LL;  // Begin Triggerblock ... 07:30:00.250 2024 (UTC)
  EXPECT_EQ(frames[0].timestamp_ns, start + 1'000'000);
  EXPECT_EQ(frames[0].id, 0x123u);
  EXPECT_EQ(frames[0].len, 4);
  EXPECT_EQ(frames[0].data[3], 0xEF);
  EXPECT_EQ(log->bus_names()[frames[0].bus], "can0");  // channel 1
  EXPECT_EQ(frames[1].id, 0x1ABCDEF0u);
  EXPECT_TRUE(frames[1].extended());
  EXPECT_EQ(log->bus_names()[frames[1].bus], "can1");
  EXPECT_EQ(frames[1].timestamp_ns, start + 2'500'000);
  EXPECT_TRUE(frames[2].remote());
  EXPECT_EQ(frames[2].len, 2);
  EXPECT_TRUE(frames[3].error());
  EXPECT_TRUE(frames[4].fd());
  EXPECT_TRUE(frames[4].flags & kFlagFdBrs);
  EXPECT_EQ(frames[4].id, 0x7FFu);
  EXPECT_EQ(frames[4].len, 12);
  EXPECT_EQ(frames[4].data[11], 0x0B);
  EXPECT_EQ(log->bus_names()[frames[4].bus], "can2");
  EXPECT_EQ(frames[5].id, 0x124u);
  EXPECT_EQ(log->counters().malformed, 2u);
  ASSERT_EQ(log->first_malformed().size(), 2u);
  EXPECT_EQ(log->first_malformed()[0].position, 13u);
  EXPECT_EQ(log->first_malformed()[0].reason, "bad data byte");
  EXPECT_EQ(log->Locate(log->first_malformed()[1]), dir.File("a.asc") + ":14: not an ASC header or event line");
  EXPECT_EQ(log->skipped_records(), 2u);  // Start of measurement, Statistic
  EXPECT_EQ(log->counters().error_frames, 1u);
  EXPECT_TRUE(log->io_error().empty());
}

TEST(AscReader, DecimalBaseAndRelativeTimestamps) {
  TempDir dir;
  WriteFile(dir.File("d.asc"),
            "date Mon Mar 4 07:30:00 pm 2024\nbase dec  timestamps relative\nno internal events logged\n"
            "   0.100000 1  291             Rx   d 2 222 173\n"
            "   0.050000 1  100x            Rx   d 1 7\n");
  auto log = OpenFrameLog(dir.File("d.asc"));
  const auto frames = ReadAll(*log);
  ASSERT_EQ(frames.size(), 2u);
  const int64_t start = 1709580600'000'000'000LL;  // 19:30:00 UTC
  EXPECT_EQ(frames[0].timestamp_ns, start + 100'000'000);
  EXPECT_EQ(frames[1].timestamp_ns, start + 150'000'000);  // relative: delta to the previous event
  EXPECT_EQ(frames[0].id, 291u);
  EXPECT_EQ(frames[0].data[0], 222);
  EXPECT_EQ(frames[1].id, 100u);
  EXPECT_TRUE(frames[1].extended());
}

// python-can's ASCWriter writes a classic message given 64 bytes as "d 40" (the length in hex)
// with all 64 bytes, and its reader takes the first 8. Catches: "bad DLC" for a DLC above 15,
// more than 8 bytes in a classic frame.
TEST(AscReader, ClassicFrameWithMoreThanEightBytesReadsTheFirstEight) {
  TempDir dir;
  std::string line = " 0.000000 1  123x            Rx   d 40";
  for (int i = 0; i < 64; ++i) line += " " + std::string(1, "0123456789ABCDEF"[i / 16]) + "0123456789ABCDEF"[i % 16];
  WriteFile(dir.File("s.asc"), "base hex  timestamps absolute\nBegin Triggerblock Sat Sep 30 15:06:13.191 2017\n" + line +
                                   "\n 0.000001 1  124 Rx d F 01 02 03 04 05 06 07 08\n");
  auto log = OpenFrameLog(dir.File("s.asc"));
  const auto frames = ReadAll(*log);
  EXPECT_EQ(log->counters().malformed, 0u);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].len, 8);
  EXPECT_FALSE(frames[0].fd());
  EXPECT_EQ(frames[0].data[7], 7);
  EXPECT_EQ(frames[1].len, 8);
}

// Vector writes "07:30:00.004"; python-can writes the milliseconds unpadded, "07:30:00.4".
TEST(AscReader, StartDateMillisecondsWithFewerDigitsCountMilliseconds) {
  TempDir dir;
  const int64_t start = 1709537400'000'000'000LL;
  const std::pair<const char*, int64_t> cases[] = {
      {"07:30:00.004", 4'000'000}, {"07:30:00.4", 4'000'000}, {"07:30:00.45", 45'000'000},
      {"07:30:00.450", 450'000'000}, {"07:30:00.123456", 123'456'000}};
  for (const auto& [clock, offset] : cases) {
    WriteFile(dir.File("t.asc"), std::string("base hex  timestamps absolute\nBegin Triggerblock Mon Mar 4 ") + clock +
                                     " 2024\n 0.000001 1  100 Rx d 0\n");
    auto log = OpenFrameLog(dir.File("t.asc"));
    const auto frames = ReadAll(*log);
    ASSERT_EQ(frames.size(), 1u) << clock;
    EXPECT_EQ(frames[0].timestamp_ns, start + offset + 1000) << clock;
  }
}

TEST(AscReader, TruncatedGzipStopsWithAnIoError) {
  TempDir dir;
  std::string text = kAsc;
  for (int i = 0; i < 3000; ++i) text += "   1.000000 1  125             Rx   d 2 01 02\n";
  WriteGzip(dir.File("full.gz"), text);
  const std::string gz = ReadFile(dir.File("full.gz"));
  WriteFile(dir.File("cut.gz"), gz.substr(0, gz.size() / 2));
  auto log = OpenFrameLog(dir.File("cut.gz"));
  const auto frames = ReadAll(*log);
  EXPECT_GT(frames.size(), 0u);
  EXPECT_LT(frames.size(), 3006u);
  EXPECT_NE(log->io_error().find("truncated"), std::string::npos) << log->io_error();
}

std::string AllBlfObjects() {
  std::string inner;
  inner += BlfObject(1, 1'000'000, BlfCanBody(1, 0, 4, 0x123, "\xDE\xAD\xBE\xEF"));
  inner += BlfObject(86, 2'000'000, BlfCanBody(2, 0, 8, 0x80000000u | 0x1ABCDEF0u, "12345678") + std::string(8, '\0'));
  inner += BlfObject(1, 300, BlfCanBody(1, 0x80, 3, 0x321, ""), 1);  // 10 us units: 3 ms
  // CAN_FD_MESSAGE: channel, flags, dlc 9, id, frame length, bit count, fd flags EDL|BRS, 12 valid, 5 pad, 64 data
  std::string fd = Le<uint16_t>(3) + Le<uint8_t>(0) + Le<uint8_t>(9) + Le<uint32_t>(0x7FF) + Le<uint32_t>(0) +
                   Le<uint8_t>(0) + Le<uint8_t>(3) + Le<uint8_t>(12) + std::string(5, '\0');
  std::string payload(64, '\0');
  for (int i = 0; i < 64; ++i) payload[static_cast<size_t>(i)] = static_cast<char>(i + 1);
  inner += BlfObject(100, 4'000'000, fd + payload);
  // CAN_FD_MESSAGE_64: channel, dlc 15, valid 64, tx count, id ext, frame length, flags EDL|ESI, ...
  std::string fd64 = Le<uint8_t>(1) + Le<uint8_t>(15) + Le<uint8_t>(64) + Le<uint8_t>(0) +
                     Le<uint32_t>(0x80000000u | 0x100u) + Le<uint32_t>(0) + Le<uint32_t>(0x1000 | 0x4000) +
                     std::string(16, '\0') + Le<uint16_t>(0) + Le<uint8_t>(0) + Le<uint8_t>(0) + Le<uint32_t>(0);
  inner += BlfObject(101, 5'000'000, fd64 + payload);
  inner += BlfObject(73, 6'000'000, Le<uint16_t>(1) + std::string(30, '\0'));  // CAN_ERROR_EXT
  inner += BlfObject(96, 6'500'000, std::string(40, '\0'));                     // GLOBAL_MARKER: skipped
  inner += BlfObject(1, 7'000'000, BlfCanBody(1, 0, 1, 0x124, "\x42"));
  return inner;
}

// Found by the blf fuzz target (heap-buffer-overflow, tests/fuzz/regressions/blf/crash-81bf...):
// a CAN_FD_MESSAGE_64 whose extended-data offset points past the object made the reader copy the
// bytes after it. Catches: data taken from beyond the object; the missing bytes read as zero.
TEST(BlfReader, FdMessage64DataEndsAtTheObjectWhateverItsExtOffsetSays) {
  TempDir dir;
  // dlc 15, valid 64, flags EDL; ext_offset (body byte 37) 0xFF, far beyond the 48-byte body.
  const std::string fd64 = Le<uint8_t>(1) + Le<uint8_t>(15) + Le<uint8_t>(64) + Le<uint8_t>(0) + Le<uint32_t>(0x100u) +
                           Le<uint32_t>(0) + Le<uint32_t>(0x1000) + std::string(16, '\0') + Le<uint16_t>(0) +
                           Le<uint8_t>(0) + Le<uint8_t>(0) + Le<uint32_t>(0xFF00);
  std::string inner = BlfObject(101, 1'000'000, fd64 + "ABCDEFGH");
  inner += BlfObject(1, 2'000'000, BlfCanBody(1, 0, 8, 0x124, "\x7F\x7F\x7F\x7F\x7F\x7F\x7F\x7F"));
  WriteFile(dir.File("a.blf"), BlfFile(BlfContainer(inner)));
  auto log = OpenFrameLog(dir.File("a.blf"));
  const auto f = ReadAll(*log);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_EQ(f[0].len, 64);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(f[0].data.data()), 8), "ABCDEFGH");
  for (size_t i = 8; i < 64; ++i) EXPECT_EQ(f[0].data[i], 0) << i;
  EXPECT_EQ(f[1].id, 0x124u);
}

TEST(BlfReader, ReadsEveryObjectKindAcrossContainerBoundaries) {
  TempDir dir;
  const std::string inner = AllBlfObjects();
  // Split the object stream in the middle of an object: the reader must join the containers.
  const size_t cut = 50;
  WriteFile(dir.File("a.blf"), BlfFile(BlfContainer(inner.substr(0, cut)) + BlfContainer(inner.substr(cut), false)));
  auto log = OpenFrameLog(dir.File("a.blf"));
  ASSERT_EQ(log->format(), LogFormat::kBlf);
  const auto f = ReadAll(*log);
  ASSERT_EQ(f.size(), 7u);
  EXPECT_EQ(f[0].timestamp_ns, kBlfStartNs + 1'000'000);
  EXPECT_EQ(f[0].id, 0x123u);
  EXPECT_EQ(f[0].len, 4);
  EXPECT_EQ(f[0].data[0], 0xDE);
  EXPECT_EQ(log->bus_names()[f[0].bus], "can0");
  EXPECT_TRUE(f[1].extended());
  EXPECT_EQ(f[1].id, 0x1ABCDEF0u);
  EXPECT_EQ(f[1].data[7], '8');
  EXPECT_EQ(log->bus_names()[f[1].bus], "can1");
  EXPECT_EQ(f[2].timestamp_ns, kBlfStartNs + 3'000'000);  // 300 x 10 us
  EXPECT_TRUE(f[2].remote());
  EXPECT_EQ(f[2].len, 3);
  EXPECT_TRUE(f[3].fd());
  EXPECT_TRUE(f[3].flags & kFlagFdBrs);
  EXPECT_EQ(f[3].len, 12);
  EXPECT_EQ(f[3].data[11], 12);
  EXPECT_TRUE(f[4].fd() && f[4].extended());
  EXPECT_TRUE(f[4].flags & kFlagFdEsi);
  EXPECT_EQ(f[4].len, 64);
  EXPECT_EQ(f[4].data[63], 64);
  EXPECT_TRUE(f[5].error());
  EXPECT_EQ(f[6].id, 0x124u);
  EXPECT_EQ(log->skipped_records(), 1u);
  EXPECT_EQ(log->counters().malformed, 0u);
  EXPECT_TRUE(log->io_error().empty()) << log->io_error();
}

TEST(BlfReader, TruncatedFileIsReportedNotAcceptedSilently) {
  TempDir dir;
  const std::string inner = AllBlfObjects();
  const std::string full = BlfFile(BlfContainer(inner.substr(0, 200)) + BlfContainer(inner.substr(200)));
  // Cut inside the second container.
  WriteFile(dir.File("cut.blf"), full.substr(0, full.size() - 40));
  auto log = OpenFrameLog(dir.File("cut.blf"));
  const auto frames = ReadAll(*log);
  EXPECT_LT(frames.size(), 7u);
  EXPECT_NE(log->io_error().find("truncated"), std::string::npos) << log->io_error();
  // Cut exactly between containers: the header's file size gives it away.
  const std::string first = BlfFile(BlfContainer(inner.substr(0, 200)) + BlfContainer(inner.substr(200)));
  WriteFile(dir.File("cut2.blf"), first.substr(0, 144 + BlfContainer(inner.substr(0, 200)).size()));
  auto log2 = OpenFrameLog(dir.File("cut2.blf"));
  ReadAll(*log2);
  EXPECT_NE(log2->io_error().find("truncated"), std::string::npos) << log2->io_error();
  // A file cut inside its header cannot be opened at all.
  WriteFile(dir.File("cut3.blf"), full.substr(0, 60));
  EXPECT_THROW(OpenFrameLog(dir.File("cut3.blf")), Error);
}

TEST(BlfReader, CorruptContainerIsCountedAndReadingGoesOn) {
  TempDir dir;
  std::string bad = BlfContainer(BlfObject(1, 10, BlfCanBody(1, 0, 1, 0x100, "A")));
  bad[40] = static_cast<char>(bad[40] ^ 0xFF);  // inside the deflate stream
  bad[41] = static_cast<char>(bad[41] ^ 0xFF);
  const std::string good = BlfContainer(BlfObject(1, 20, BlfCanBody(1, 0, 1, 0x101, "B")));
  WriteFile(dir.File("c.blf"), BlfFile(bad + good));
  auto log = OpenFrameLog(dir.File("c.blf"));
  const auto frames = ReadAll(*log);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].id, 0x101u);
  EXPECT_EQ(log->counters().malformed, 1u);
  ASSERT_EQ(log->first_malformed().size(), 1u);
  EXPECT_EQ(log->first_malformed()[0].position, 144u);  // the broken container's file offset
  EXPECT_EQ(log->Locate(log->first_malformed()[0]),
            dir.File("c.blf") + ": byte 144: log container does not decompress (corrupt zlib data)");
}

// The fuzz targets' seeds and every input a fuzzer once crashed on (tests/fuzz/regressions/):
// each opens or fails with an Error, and reads to the end without crashing.
TEST(FrameLog, FuzzSeedsAndFindingsReadWithoutCrashing) {
  int files = 0;
  for (const char* kind : {"corpus", "regressions"}) {
    for (const char* name : {"asc", "blf", "mf4"}) {
      const fs::path dir = fs::path(NDSID_SOURCE_DIR) / "tests/fuzz" / kind / name;
      if (!fs::exists(dir)) continue;
      for (const auto& entry : fs::directory_iterator(dir)) {
        SCOPED_TRACE(entry.path().string());
        ++files;
        try {
          auto log = OpenFrameLog(entry.path().string());
          for (const CanFrame& f : ReadAll(*log, 64)) {
            ASSERT_LE(f.len, kMaxPayload);
            ASSERT_LT(f.bus, log->bus_names().size());
          }
        } catch (const Error&) {
        }
      }
    }
  }
  EXPECT_GE(files, 5);
}

}  // namespace
}  // namespace ndsid::can
