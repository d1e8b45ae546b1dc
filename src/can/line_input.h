// Lines of a text file, plain or gzip (zlib's gzread detects which), through a fixed buffer.
// Lines longer than kMaxLineBytes are returned truncated with too_long() set.
#pragma once

#include <zlib.h>

#include <string>
#include <string_view>
#include <vector>

namespace ndsid::can::detail {

class LineInput {
 public:
  // False (with error() set) when the file cannot be opened.
  bool Open(const std::string& path) noexcept;
  ~LineInput();

  // The next line without its '\n' (and '\r'), or false at the end of input or after an error.
  bool Next(std::string_view& line) noexcept;
  uint64_t line_number() const noexcept { return line_number_; }
  bool too_long() const noexcept { return too_long_; }
  // Empty unless reading stopped on a read or decompression error (truncated gzip, ...).
  const std::string& error() const noexcept { return error_; }
  bool compressed() const noexcept;
  // Bytes of the file consumed (compressed bytes for gzip).
  uint64_t raw_offset() const noexcept;

  static constexpr size_t kMaxLineBytes = 4096;

 private:
  bool Fill() noexcept;

  gzFile file_ = nullptr;
  std::vector<char> buffer_ = std::vector<char>(1 << 16);
  size_t begin_ = 0, end_ = 0;
  bool eof_ = false;
  bool too_long_ = false;
  uint64_t line_number_ = 0;
  std::string error_;
};

}  // namespace ndsid::can::detail
