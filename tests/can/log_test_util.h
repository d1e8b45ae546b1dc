// Helpers of the log-format tests: a temporary folder, file writers, read-everything, and a
// minimal BLF writer (objects, containers, file header) that follows the layout comment of
// src/can/blf_reader.cc, so hand-made and broken BLF files can be built byte by byte.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "ndsid/can/frame_log.h"

namespace ndsid::can::testing {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "ndsid_log_XXXXXX").string();
    path_ = mkdtemp(pattern.data());
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

inline void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

inline std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline void WriteGzip(const std::string& path, const std::string& bytes) {
  gzFile f = gzopen(path.c_str(), "wb6");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size())), static_cast<int>(bytes.size()));
  gzclose(f);
}

inline std::vector<CanFrame> ReadAll(FrameSource& log, size_t chunk = 7) {
  std::vector<CanFrame> all;
  std::vector<CanFrame> buf(chunk);
  for (;;) {
    const ReadResult r = log.Read(buf, 0);
    if (r.state == SourceState::kEnd) break;
    all.insert(all.end(), buf.begin(), buf.begin() + static_cast<ptrdiff_t>(r.count));
  }
  return all;
}

// Little-endian integers as bytes.
template <typename T>
std::string Le(T v) {
  std::string s(sizeof(T), '\0');
  for (size_t i = 0; i < sizeof(T); ++i) s[i] = static_cast<char>((static_cast<uint64_t>(v) >> (8 * i)) & 0xFF);
  return s;
}

// One BLF object with a version-1 header; flags 2 = time in ns, 1 = time in 10 us.
inline std::string BlfObject(uint32_t type, uint64_t time, const std::string& body, uint32_t flags = 2) {
  std::string o = "LOBJ" + Le<uint16_t>(32) + Le<uint16_t>(1) + Le<uint32_t>(32 + static_cast<uint32_t>(body.size())) +
                  Le<uint32_t>(type) + Le<uint32_t>(flags) + Le<uint16_t>(0) + Le<uint16_t>(0) + Le<uint64_t>(time) + body;
  return o + std::string(body.size() % 4, '\0');
}

// The same with a version-2 header (40 bytes: flags, time status, object version, time, original time).
inline std::string BlfObjectV2(uint32_t type, uint64_t time, const std::string& body, uint32_t flags = 2) {
  std::string o = "LOBJ" + Le<uint16_t>(40) + Le<uint16_t>(2) + Le<uint32_t>(40 + static_cast<uint32_t>(body.size())) +
                  Le<uint32_t>(type) + Le<uint32_t>(flags) + Le<uint8_t>(0) + Le<uint8_t>(0) + Le<uint16_t>(0) +
                  Le<uint64_t>(time) + Le<uint64_t>(0) + body;
  return o + std::string(body.size() % 4, '\0');
}

// CAN_MESSAGE (type 1) body: channel, flags (0x80 remote), dlc, id (bit 31 extended), 8 bytes.
inline std::string BlfCanBody(uint16_t channel, uint8_t flags, uint8_t dlc, uint32_t id, const std::string& data) {
  std::string d = data;
  d.resize(8, '\0');
  return Le(channel) + Le(flags) + Le(dlc) + Le(id) + d;
}

// A LOG_CONTAINER holding `inner` (zlib-compressed unless compress is false).
inline std::string BlfContainer(const std::string& inner, bool compress = true) {
  std::string data = inner;
  if (compress) {
    uLongf n = compressBound(static_cast<uLong>(inner.size()));
    data.assign(n, '\0');
    compress2(reinterpret_cast<Bytef*>(data.data()), &n, reinterpret_cast<const Bytef*>(inner.data()),
              static_cast<uLong>(inner.size()), 6);
    data.resize(n);
  }
  const uint32_t size = 32 + static_cast<uint32_t>(data.size());
  std::string c = "LOBJ" + Le<uint16_t>(16) + Le<uint16_t>(1) + Le(size) + Le<uint32_t>(10) +
                  Le<uint16_t>(compress ? 2 : 0) + std::string(6, '\0') + Le<uint32_t>(static_cast<uint32_t>(inner.size())) +
                  std::string(4, '\0') + data;
  return c + std::string(size % 4, '\0');
}

// File header (144 bytes) with start time 2024-03-04 07:30:00.250 UTC, then the containers.
inline std::string BlfFile(const std::string& containers, uint64_t declared_size = 0) {
  std::string h = "LOGG" + Le<uint32_t>(144) + std::string(8, '\0') +
                  Le<uint64_t>(declared_size != 0 ? declared_size : 144 + containers.size()) + Le<uint64_t>(0) +
                  Le<uint32_t>(0) + Le<uint32_t>(0);
  for (uint16_t v : {2024, 3, 1, 4, 7, 30, 0, 250}) h += Le<uint16_t>(v);
  h += std::string(16, '\0');
  h.resize(144, '\0');
  return h + containers;
}

// 2024-03-04 07:30:00.250 UTC in ns since 1970.
inline constexpr int64_t kBlfStartNs = 1709537400'250'000'000LL;

}  // namespace ndsid::can::testing
