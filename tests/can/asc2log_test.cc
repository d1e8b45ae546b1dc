// A fixture written by can-utils itself: the test writes a Vector ASC file, Debian's asc2log
// (can-utils 2020.11) converts it to a candump log at test time, and CandumpReader must return
// exactly the frames the ASC file holds. asc2log appends a direction token (" R"/" T") to
// every line, as newer candump versions do; the reader accepts it.
//
// asc2log 2020.11 silently drops two kinds of ASC records, so the fixture avoids them:
// classic frames with DLC > 8 and CANFD records of 8 bytes or fewer.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "ndsid/can/candump_reader.h"

namespace ndsid::can {
namespace {

namespace fs = std::filesystem;

struct Expected {
  int64_t time_ns;  // time written in the ASC file
  std::string bus;
  CanFrame frame;
};

std::string Hex2(uint8_t b) {
  char s[4];
  std::snprintf(s, sizeof s, "%02X", b);
  return s;
}

// Writes the ASC body and the frames each line must become.
std::string MakeAsc(std::vector<Expected>& expected) {
  std::string asc = "base hex  timestamps absolute\nno internal events logged\n";
  std::mt19937 rng(42);
  const int fd_lengths[] = {12, 16, 20, 24, 32, 48, 64};
  const int fd_dlc[] = {9, 10, 11, 12, 13, 14, 15};
  int64_t t_us = 1000;
  for (int i = 0; i < 600; ++i) {
    t_us += 1 + static_cast<int64_t>(rng() % 5000);
    const int channel = 1 + static_cast<int>(rng() % 3);
    char time[32];
    std::snprintf(time, sizeof time, "%lld.%06lld", static_cast<long long>(t_us / 1000000),
                  static_cast<long long>(t_us % 1000000));
    Expected e{t_us * 1000, "can" + std::to_string(channel - 1), CanFrame{}};
    CanFrame& f = e.frame;
    const bool extended = rng() % 3 == 0;
    f.id = static_cast<uint32_t>(rng()) & (extended ? kExtendedIdMask : kStandardIdMask);
    f.flags = extended ? kFlagExtended : 0;
    char id[16];
    std::snprintf(id, sizeof id, extended ? "%Xx" : "%X", f.id);
    const int kind = i == 0 ? 0 : static_cast<int>(rng() % 10);
    std::string line = std::string("   ") + time + " ";
    if (kind < 6) {  // classic data
      f.len = static_cast<uint8_t>(rng() % 9);
      line += std::to_string(channel) + "  " + id + "  Rx   d " + std::to_string(f.len);
      for (int b = 0; b < f.len; ++b) {
        f.data[b] = static_cast<uint8_t>(rng());
        line += " " + Hex2(f.data[b]);
      }
    } else if (kind == 6) {  // remote, with or without DLC
      f.flags |= kFlagRemote;
      f.len = static_cast<uint8_t>(rng() % 9);
      line += std::to_string(channel) + "  " + id + "  Tx   r";
      if (f.len > 0 || rng() % 2) line += " " + std::to_string(f.len);
    } else if (kind == 7) {  // error frame: asc2log writes CAN_ERR_BUSERROR
      f = CanFrame{};
      f.flags = kFlagError;
      f.id = 0x80;
      f.len = 8;
      line += std::to_string(channel) + "  ErrorFrame";
    } else {  // CAN FD, more than 8 bytes
      const int k = static_cast<int>(rng() % 7);
      const bool brs = rng() % 2;
      const bool esi = rng() % 2;
      f.flags |= kFlagFd | (brs ? kFlagFdBrs : 0) | (esi ? kFlagFdEsi : 0);
      f.len = static_cast<uint8_t>(fd_lengths[k]);
      char head[96];
      std::snprintf(head, sizeof head, "CANFD %3d Rx %10s %d %d %x %d", channel, id, brs, esi, fd_dlc[k], f.len);
      line += head;
      for (int b = 0; b < f.len; ++b) {
        f.data[b] = static_cast<uint8_t>(rng());
        line += " " + Hex2(f.data[b]);
      }
      char tail[96];
      std::snprintf(tail, sizeof tail, "   130000  130 %08X 00000000 00000000 00000000 00000000 00000000",
                    0x1000u | (brs ? 0x2000u : 0u) | (esi ? 0x4000u : 0u));
      line += tail;
    }
    asc += line + "\n";
    expected.push_back(e);
  }
  return asc;
}

TEST(Asc2logFixture, ReaderReturnsExactlyTheFramesOfTheAscFile) {
  const std::string asc2log = NDSID_ASC2LOG;
  if (asc2log.empty() || asc2log.ends_with("NOTFOUND") || !fs::exists(asc2log)) {
    GTEST_SKIP() << "can-utils asc2log not installed (apt install can-utils); cannot make the fixture";
  }
  std::string pattern = (fs::temp_directory_path() / "ndsid_asc_XXXXXX").string();
  const fs::path dir = mkdtemp(pattern.data());
  std::vector<Expected> expected;
  std::ofstream(dir / "in.asc") << MakeAsc(expected);
  const std::string command = "'" + asc2log + "' -I '" + (dir / "in.asc").string() + "' -O '" +
                              (dir / "out.log").string() + "' 2>'" + (dir / "stderr.txt").string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;

  CandumpReader reader((dir / "out.log").string());
  std::vector<CanFrame> frames;
  std::vector<CanFrame> chunk(64);
  for (ReadResult r; (r = reader.Read(chunk, 0)).state == SourceState::kOk;) {
    frames.insert(frames.end(), chunk.begin(), chunk.begin() + static_cast<ptrdiff_t>(r.count));
  }
  EXPECT_EQ(reader.counters().malformed, 0u)
      << (reader.first_malformed().empty() ? "" : reader.first_malformed()[0].reason);
  ASSERT_EQ(frames.size(), expected.size()) << "asc2log output: " << (dir / "out.log");
  for (size_t i = 0; i < frames.size(); ++i) {
    const CanFrame& got = frames[i];
    const CanFrame& want = expected[i].frame;
    SCOPED_TRACE("frame " + std::to_string(i) + ": " + FormatCandumpLine(got, reader.bus_names()[got.bus]));
    // asc2log adds the file's start date when it can parse one; compare times relative to the first.
    EXPECT_EQ(got.timestamp_ns - frames[0].timestamp_ns, expected[i].time_ns - expected[0].time_ns);
    EXPECT_EQ(reader.bus_names()[got.bus], expected[i].bus);
    EXPECT_EQ(got.id, want.id);
    EXPECT_EQ(got.flags, want.flags);
    EXPECT_EQ(got.len, want.len);
    EXPECT_EQ(got.data, want.data);
  }
  size_t errors = 0;
  for (const auto& e : expected) errors += e.frame.error();
  EXPECT_EQ(reader.counters().error_frames, errors);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ndsid::can
