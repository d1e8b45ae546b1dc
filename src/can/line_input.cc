#include "line_input.h"

#include <cerrno>
#include <cstring>

namespace ndsid::can::detail {

bool LineInput::Open(const std::string& path) noexcept {
  file_ = gzopen(path.c_str(), "rb");
  if (file_ == nullptr) {
    error_ = std::strerror(errno);
    return false;
  }
  gzbuffer(file_, 1 << 17);
  return true;
}

LineInput::~LineInput() {
  if (file_ != nullptr) gzclose(file_);
}

bool LineInput::compressed() const noexcept { return file_ != nullptr && gzdirect(file_) == 0; }

uint64_t LineInput::raw_offset() const noexcept {
  const z_off_t at = file_ ? gzoffset(file_) : -1;
  return at > 0 ? static_cast<uint64_t>(at) : 0;
}

bool LineInput::Fill() noexcept {
  if (eof_) return false;
  if (begin_ > 0) {
    std::memmove(buffer_.data(), buffer_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  const int n = gzread(file_, buffer_.data() + end_, static_cast<unsigned>(buffer_.size() - end_));
  if (n > 0) end_ += static_cast<size_t>(n);
  int err = Z_OK;
  const char* message = gzerror(file_, &err);
  if (n < 0 || (err != Z_OK && err != Z_STREAM_END)) {
    eof_ = true;
    error_ = err == Z_BUF_ERROR ? "unexpected end of compressed data (truncated gzip file?)"
                                : std::string(message != nullptr ? message : "read error");
    return n > 0;
  }
  if (n == 0) eof_ = true;
  return n > 0;
}

bool LineInput::Next(std::string_view& line) noexcept {
  for (;;) {
    const char* start = buffer_.data() + begin_;
    const void* newline = std::memchr(start, '\n', end_ - begin_);
    size_t length = 0;
    if (newline != nullptr) {
      length = static_cast<size_t>(static_cast<const char*>(newline) - start);
      begin_ += length + 1;
      too_long_ = false;
    } else if (end_ - begin_ > kMaxLineBytes) {  // keep the start, drop the rest of the line
      length = kMaxLineBytes;
      too_long_ = true;
      for (;;) {
        begin_ = end_;
        if (!Fill()) break;
        const void* nl = std::memchr(buffer_.data(), '\n', end_);
        if (nl != nullptr) {
          begin_ = static_cast<size_t>(static_cast<const char*>(nl) - buffer_.data()) + 1;
          break;
        }
      }
      // the kept start was overwritten by Fill(): return an empty too-long line
      ++line_number_;
      line = std::string_view();
      return true;
    } else if (Fill()) {
      continue;
    } else {
      if (begin_ == end_) return false;
      start = buffer_.data() + begin_;  // Fill() may have moved the tail
      length = end_ - begin_;  // last line without a newline
      begin_ = end_;
      too_long_ = false;
    }
    ++line_number_;
    if (length > 0 && start[length - 1] == '\r') --length;
    line = std::string_view(start, length);
    return true;
  }
}

}  // namespace ndsid::can::detail
