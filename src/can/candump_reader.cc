// CandumpReader: zlib's gzread reads gzip and plain files alike (it checks the magic bytes),
// through a fixed buffer; lines are parsed in place, without allocation per frame.
#include "ndsid/can/candump_reader.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "can_logger.h"
#include "candump_line.h"
#include "ndsid/common/error.h"

namespace ndsid::can {

namespace {
constexpr size_t kBufferBytes = 1 << 16;
constexpr unsigned kZlibBufferBytes = 1 << 17;
}  // namespace

struct CandumpReader::Impl {
  std::string path;
  gzFile file = nullptr;
  uint64_t file_size = 0;  // at open, for fraction_read; 0 when unknown
  std::shared_ptr<spdlog::logger> log;
  std::vector<char> buffer = std::vector<char>(kBufferBytes);
  size_t begin = 0;  // unread bytes are buffer[begin, end)
  size_t end = 0;
  bool eof = false;
  bool skipping_long_line = false;  // discarding the rest of an over-long line
  uint64_t line_number = 0;
  int64_t last_timestamp_ns = INT64_MIN;
  uint16_t last_bus = 0;
  SourceCounters counters;
  std::vector<std::string> bus_names;
  std::vector<MalformedLine> first_malformed;
  std::string io_error;

  // Refills the buffer after moving the unread tail to the front. False at end of input.
  bool Fill() noexcept;
  // Next complete line (without '\n'), or false at end of input.
  bool NextLine(std::string_view& line) noexcept;
  void Reject(const char* reason) noexcept;
  int BusIndex(std::string_view name) noexcept;
};

bool CandumpReader::Impl::Fill() noexcept {
  if (eof) return false;
  if (begin > 0) {
    std::memmove(buffer.data(), buffer.data() + begin, end - begin);
    end -= begin;
    begin = 0;
  }
  const int n = gzread(file, buffer.data() + end, static_cast<unsigned>(buffer.size() - end));
  if (n > 0) end += static_cast<size_t>(n);
  int err = Z_OK;
  const char* message = gzerror(file, &err);
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END)) {
    eof = true;  // keep what was read, report the error once
    try {
      io_error = err == Z_BUF_ERROR ? "unexpected end of compressed data (truncated gzip file?)"
                                    : std::string(message != nullptr ? message : "read error");
      log->error("{}: reading stopped after line {}: {}", path, line_number, io_error);
    } catch (...) {
    }
    return n > 0;
  }
  if (n == 0) eof = true;
  return n > 0;
}

bool CandumpReader::Impl::NextLine(std::string_view& line) noexcept {
  for (;;) {
    const char* start = buffer.data() + begin;
    const void* newline = std::memchr(start, '\n', end - begin);
    if (newline != nullptr) {
      const size_t length = static_cast<size_t>(static_cast<const char*>(newline) - start);
      begin += length + 1;
      if (skipping_long_line) {  // the tail of a line already counted as too long
        skipping_long_line = false;
        continue;
      }
      ++line_number;
      if (length > kMaxLineBytes) {
        Reject("line longer than 512 bytes");
        continue;
      }
      line = std::string_view(start, length);
      return true;
    }
    if (end - begin > kMaxLineBytes) {  // no newline within the limit: reject, skip the rest
      if (!skipping_long_line) {
        ++line_number;
        Reject("line longer than 512 bytes");
        skipping_long_line = true;
      }
      begin = end;
    }
    if (!Fill()) {
      if (begin == end || skipping_long_line) return false;
      ++line_number;  // last line without a newline
      line = std::string_view(buffer.data() + begin, end - begin);
      begin = end;
      return true;
    }
  }
}

void CandumpReader::Impl::Reject(const char* reason) noexcept {
  ++counters.malformed;
  if (first_malformed.size() >= kKeptMalformed) return;
  try {
    first_malformed.push_back({line_number, reason});
    log->warn("{}", FormatLocation(path, static_cast<int>(line_number), 0, reason));
    if (first_malformed.size() == kKeptMalformed) {
      log->warn("{}: further malformed lines are counted, not logged", path);
    }
  } catch (...) {
  }
}

int CandumpReader::Impl::BusIndex(std::string_view name) noexcept {
  if (last_bus < bus_names.size() && bus_names[last_bus] == name) return last_bus;
  for (size_t i = 0; i < bus_names.size(); ++i) {
    if (bus_names[i] == name) return static_cast<int>(last_bus = static_cast<uint16_t>(i));
  }
  if (bus_names.size() >= kMaxBuses) return -1;
  try {
    bus_names.emplace_back(name);
  } catch (...) {
    return -1;
  }
  return last_bus = static_cast<uint16_t>(bus_names.size() - 1);
}

CandumpReader::CandumpReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->log = CanLogger();
  impl_->file = gzopen(path.c_str(), "rb");
  if (impl_->file == nullptr) {
    throw Error("candump log " + path + ": cannot open: " + std::strerror(errno));
  }
  gzbuffer(impl_->file, kZlibBufferBytes);
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  impl_->file_size = ec ? 0 : static_cast<uint64_t>(size);
}

CandumpReader::~CandumpReader() {
  if (impl_->file != nullptr) gzclose(impl_->file);
}

ReadResult CandumpReader::Read(std::span<CanFrame> out, int /*timeout_ms*/) noexcept {
  Impl& s = *impl_;
  if (out.empty()) return {0, SourceState::kOk};  // nothing asked, nothing consumed
  size_t count = 0;
  std::string_view line;
  while (count < out.size() && s.NextLine(line)) {
    if (detail::IsBlankOrComment(line)) continue;
    CanFrame& frame = out[count];
    std::string_view bus_name;
    if (const char* why = detail::ParseLine(line, frame, bus_name)) {
      s.Reject(why);
      continue;
    }
    const int bus = s.BusIndex(bus_name);
    if (bus < 0) {
      s.Reject("too many distinct interface names");
      continue;
    }
    frame.bus = static_cast<uint16_t>(bus);
    if (frame.timestamp_ns < s.last_timestamp_ns) ++s.counters.time_backwards;
    s.last_timestamp_ns = frame.timestamp_ns;
    if (frame.error()) ++s.counters.error_frames;
    ++s.counters.frames;
    ++count;
  }
  return {count, count > 0 ? SourceState::kOk : SourceState::kEnd};
}

const SourceCounters& CandumpReader::counters() const noexcept { return impl_->counters; }
const std::vector<std::string>& CandumpReader::bus_names() const noexcept { return impl_->bus_names; }
const std::vector<MalformedLine>& CandumpReader::first_malformed() const noexcept {
  return impl_->first_malformed;
}
uint64_t CandumpReader::lines() const noexcept { return impl_->line_number; }
const std::string& CandumpReader::io_error() const noexcept { return impl_->io_error; }

double CandumpReader::fraction_read() const noexcept {
  const z_off_t at = impl_->file ? gzoffset(impl_->file) : -1;
  if (impl_->file_size == 0 || at < 0) return -1.0;
  return std::min(1.0, static_cast<double>(at) / static_cast<double>(impl_->file_size));
}

std::string CandumpReader::Locate(const MalformedRecord& record) const {
  return FormatLocation(impl_->path, static_cast<int>(record.position), 0, record.reason);
}

std::string CandumpReader::Describe() const {
  const bool compressed = impl_->file != nullptr && gzdirect(impl_->file) == 0;
  return "log " + impl_->path + (compressed ? " (gzip)" : "");
}

}  // namespace ndsid::can
