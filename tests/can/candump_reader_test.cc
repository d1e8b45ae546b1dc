// CandumpReader over files: plain and gzip alike, streaming through a fixed buffer, the bus
// table, malformed-line bookkeeping, time going backwards, and the real RAV4 log.
#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "ndsid/can/candump_reader.h"
#include "ndsid/common/error.h"

namespace ndsid::can {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "ndsid_can_XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

void WritePlain(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

void WriteGzip(const std::string& path, const std::string& text) {
  gzFile f = gzopen(path.c_str(), "wb6");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(gzwrite(f, text.data(), static_cast<unsigned>(text.size())), static_cast<int>(text.size()));
  gzclose(f);
}

std::vector<CanFrame> ReadAll(CandumpReader& reader, size_t chunk = 256) {
  std::vector<CanFrame> all;
  std::vector<CanFrame> buf(chunk);
  for (;;) {
    const ReadResult r = reader.Read(buf, 0);
    if (r.state == SourceState::kEnd) {
      EXPECT_EQ(r.count, 0u) << "kEnd comes with no frames";
      break;
    }
    EXPECT_EQ(r.state, SourceState::kOk);
    EXPECT_GT(r.count, 0u) << "kOk comes with frames";
    all.insert(all.end(), buf.begin(), buf.begin() + static_cast<ptrdiff_t>(r.count));
  }
  return all;
}

std::string MixedLog() {
  return "(1700000000.000100) can0 123#DEADBEEF\n"
         "(1700000000.000200) can1 18FEF100#0102030405060708\n"
         "(1700000000.000300) can0 123#R\n"
         "(1700000000.000400) can2 456##1AABB\n"
         "(1700000000.000500) can0 20000004#0004000000000000\n"
         "(1700000000.000600) can1 7FF#\n";
}

TEST(CandumpReader, MissingFileThrowsNamingThePath) {
  try {
    CandumpReader reader("/nonexistent/dir/x.log");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/x.log"), std::string::npos) << e.what();
  }
}

TEST(CandumpReader, GzipInputEqualsPlainInput) {
  TempDir dir;
  std::string text = MixedLog();
  std::mt19937 rng(7);
  for (int i = 0; i < 50000; ++i) {  // > several buffer refills in both forms
    char line[64];
    std::snprintf(line, sizeof line, "(1700000001.%06d) can%d %03X#%08X%04X\n", i % 1000000, i % 2,
                  static_cast<unsigned>(rng() & 0x7FF), static_cast<unsigned>(rng()), static_cast<unsigned>(rng() & 0xFFFF));
    text += line;
  }
  WritePlain(dir.File("a.log"), text);
  WriteGzip(dir.File("a.log.gz"), text);
  CandumpReader plain(dir.File("a.log"));
  CandumpReader gz(dir.File("a.log.gz"));
  const auto a = ReadAll(plain, 1000);
  const auto b = ReadAll(gz, 333);
  ASSERT_EQ(a.size(), 50006u);
  ASSERT_EQ(b.size(), a.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(FormatCandumpLine(a[i], plain.bus_names()[a[i].bus]),
              FormatCandumpLine(b[i], gz.bus_names()[b[i].bus])) << "frame " << i;
  }
  EXPECT_EQ(plain.bus_names(), gz.bus_names());
  EXPECT_EQ(gz.Describe(), "log " + dir.File("a.log.gz") + " (gzip)");
  EXPECT_EQ(plain.Describe(), "log " + dir.File("a.log"));
  EXPECT_TRUE(gz.io_error().empty());
}

TEST(CandumpReader, BusTableGrowsInOrderOfAppearance) {
  TempDir dir;
  WritePlain(dir.File("m.log"), MixedLog());
  CandumpReader reader(dir.File("m.log"));
  const auto frames = ReadAll(reader);
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_EQ(reader.bus_names(), (std::vector<std::string>{"can0", "can1", "can2"}));
  const std::vector<uint16_t> expected = {0, 1, 0, 2, 0, 1};
  for (size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i].bus, expected[i]) << i;
  EXPECT_TRUE(frames[3].fd());
  EXPECT_TRUE(frames[4].error());
  EXPECT_EQ(reader.counters().frames, 6u);
  EXPECT_EQ(reader.counters().error_frames, 1u) << "the error frame is counted and delivered";
  EXPECT_EQ(reader.counters().malformed, 0u);
}

TEST(CandumpReader, CountsMalformedLinesKeepsFirstTenWithLineNumbers) {
  TempDir dir;
  std::string text = "# comment written by a tool\n\n   \n";  // lines 1-3: ignored
  text += "(1.000000) can0 123#00\n";                      // line 4
  for (int i = 0; i < 25; ++i) text += "(1.000001) can0 123#0\n";  // lines 5..29: odd digits
  text += "(1.000002) can0 123#01\n";                      // line 30
  WritePlain(dir.File("bad.log"), text);
  CandumpReader reader(dir.File("bad.log"));
  const auto frames = ReadAll(reader);
  EXPECT_EQ(frames.size(), 2u);
  EXPECT_EQ(reader.counters().malformed, 25u);
  ASSERT_EQ(reader.first_malformed().size(), CandumpReader::kKeptMalformed);
  EXPECT_EQ(reader.first_malformed()[0].position, 5u);
  EXPECT_EQ(reader.first_malformed()[9].position, 14u);
  EXPECT_EQ(reader.first_malformed()[0].reason, "odd number of hex digits in data");
  EXPECT_EQ(reader.lines(), 30u);
}

TEST(CandumpReader, OverlongLineIsOneMalformedLineAndReadingContinues) {
  TempDir dir;
  std::string text = "(1.000000) can0 123#00\n";
  text += "(1.000001) can0 123#" + std::string(200000, 'A') + "\n";  // spans buffer refills
  text += "(1.000002) can0 123#" + std::string(600, 'B') + "\n";     // fits the buffer
  text += "(1.000003) can0 124#11";                                   // no final newline
  WritePlain(dir.File("long.log"), text);
  CandumpReader reader(dir.File("long.log"));
  const auto frames = ReadAll(reader);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].id, 0x124u);
  EXPECT_EQ(reader.counters().malformed, 2u);
  ASSERT_EQ(reader.first_malformed().size(), 2u);
  EXPECT_EQ(reader.first_malformed()[0].position, 2u);
  EXPECT_EQ(reader.first_malformed()[0].reason, "line longer than 512 bytes");
  EXPECT_EQ(reader.first_malformed()[1].position, 3u);
  EXPECT_EQ(reader.lines(), 4u);
}

TEST(CandumpReader, TimeGoingBackwardsIsCountedAndFrameStillDelivered) {
  TempDir dir;
  WritePlain(dir.File("t.log"),
             "(10.000000) can0 123#00\n(9.999999) can0 123#01\n(10.5) can1 123#02\n(10.5) can0 123#03\n");
  CandumpReader reader(dir.File("t.log"));
  const auto frames = ReadAll(reader);
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[1].timestamp_ns, 9999999000);
  EXPECT_EQ(reader.counters().time_backwards, 1u) << "equal times are not backwards";
}

TEST(CandumpReader, TruncatedGzipReportsIoErrorAndKeepsFramesBeforeIt) {
  TempDir dir;
  std::string text;
  for (int i = 0; i < 20000; ++i) text += "(1.000000) can0 123#0011223344556677\n";
  WriteGzip(dir.File("full.gz"), text);
  std::ifstream in(dir.File("full.gz"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  WritePlain(dir.File("cut.gz"), bytes.substr(0, bytes.size() / 2));
  CandumpReader reader(dir.File("cut.gz"));
  const auto frames = ReadAll(reader);
  EXPECT_GT(frames.size(), 0u);
  EXPECT_LT(frames.size(), 20000u);
  EXPECT_FALSE(reader.io_error().empty());
}

long RssKiB() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmRSS:") {
      long kib = 0;
      status >> kib;
      return kib;
    }
    status.ignore(1 << 12, '\n');
  }
  return -1;
}

// 2 million lines (~80 MB) read in chunks of 1000: every frame arrives, the resident set
// grows by far less than the file (it would grow by the file size if it were slurped).
TEST(CandumpReader, TwoMillionLineLogStreamsInBoundedMemory) {
  TempDir dir;
  const std::string path = dir.File("big.log");
  constexpr int kLines = 2'000'000;
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    for (int i = 0; i < kLines; ++i) {
      std::fprintf(f, "(%d.%06d) can%d %03X#%016X\n", 1000 + i / 1000000, i % 1000000, i & 1,
                   static_cast<unsigned>(i & 0x7FF), static_cast<unsigned>(i));
    }
    std::fclose(f);
  }
  const auto file_bytes = fs::file_size(path);
  ASSERT_GT(file_bytes, 60'000'000u);
  CandumpReader reader(path);
  std::vector<CanFrame> chunk(1000);
  const long rss_before = RssKiB();
  long rss_max = rss_before;
  uint64_t total = 0;
  uint64_t chunks = 0;
  for (;;) {
    const ReadResult r = reader.Read(chunk, 0);
    if (r.state == SourceState::kEnd) break;
    total += r.count;
    if (++chunks % 100 == 0) rss_max = std::max(rss_max, RssKiB());
    if (total == 1234000) {
      EXPECT_EQ(chunk[999].data[7], 1233999 & 0xFF);
    }
  }
  EXPECT_EQ(total, static_cast<uint64_t>(kLines));
  EXPECT_EQ(chunks, static_cast<uint64_t>(kLines / 1000));
  EXPECT_EQ(reader.counters().malformed, 0u);
  EXPECT_EQ(reader.counters().time_backwards, 0u);
  ASSERT_GT(rss_before, 0);
  EXPECT_LT(rss_max - rss_before, 8 * 1024) << "resident set grew by " << (rss_max - rss_before)
                                            << " KiB while reading a " << file_bytes / 1024 << " KiB file";
}

// The real comma2k19 RAV4 segment: 98 800 frames on can0 (53 800) and can1 (45 000).
TEST(CandumpReader, ReadsRealRav4SegmentCompletely) {
  const fs::path path = fs::path(NDSID_REALDATA_DIR) /
                        "comma2k19-rav4-2017-segment/derived/rav4_2017_segment40.candump.log";
  if (!fs::exists(path)) GTEST_SKIP() << "real data absent: " << path;
  CandumpReader reader(path.string());
  const auto frames = ReadAll(reader, 4096);
  EXPECT_EQ(frames.size(), 98800u);
  EXPECT_EQ(reader.counters().malformed, 0u);
  EXPECT_EQ(reader.counters().time_backwards, 0u);
  EXPECT_EQ(reader.bus_names(), (std::vector<std::string>{"can0", "can1"}));
  size_t on_can0 = 0;
  for (const auto& f : frames) on_can0 += f.bus == 0;
  EXPECT_EQ(on_can0, 53800u);
  // First line of the file: (46408.584930) can0 260#08FFFB0000001884
  EXPECT_EQ(frames[0].timestamp_ns, 46408584930000);
  EXPECT_EQ(frames[0].id, 0x260u);
  EXPECT_EQ(FormatCandumpLine(frames[0], "can0"), "(46408.584930) can0 260#08FFFB0000001884");
  // A test vector quoted in the data set's README.
  const auto it = std::find_if(frames.begin(), frames.end(),
                               [](const CanFrame& f) { return f.timestamp_ns == 46418382980000 && f.id == 0x25; });
  ASSERT_NE(it, frames.end());
  EXPECT_EQ(FormatCandumpLine(*it, "can0"), "(46418.382980) can0 025#0FFD1000FFFD0045");
  // Every line of the file is reproduced byte for byte.
  std::ifstream in(path);
  std::string line;
  size_t i = 0;
  while (std::getline(in, line) && i < frames.size()) {
    ASSERT_EQ(FormatCandumpLine(frames[i], reader.bus_names()[frames[i].bus]), line) << "line " << i + 1;
    ++i;
  }
  EXPECT_EQ(i, frames.size());
}

}  // namespace
}  // namespace ndsid::can
