// Fuzz target: a whole candump log through CandumpReader, plain or gzip. The first input byte
// chooses the form: 0 mod 3 plain, 1 gzip, 2 gzip cut short at a position taken from the second
// byte (a truncated file: the reader must stop with io_error(), not crash or loop). Frames and
// malformed lines must account for every non-blank line the reader saw.
#include <sys/mman.h>
#include <unistd.h>
#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "ndsid/can/candump_reader.h"

namespace {

std::string Gzip(const uint8_t* data, size_t size) {
  z_stream z{};
  deflateInit2(&z, Z_BEST_SPEED, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&z, size) + 32, '\0');
  z.next_in = const_cast<Bytef*>(data);
  z.avail_in = static_cast<uInt>(size);
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const int mode = data[0] % 3;
  std::string bytes = mode == 0 ? std::string(reinterpret_cast<const char*>(data + 2), size - 2) : Gzip(data + 2, size - 2);
  if (mode == 2) bytes.resize(bytes.size() * data[1] / 256);
  const int fd = memfd_create("candump", 0);
  if (fd < 0) return 0;
  if (write(fd, bytes.data(), bytes.size()) != static_cast<ssize_t>(bytes.size())) {
    close(fd);
    return 0;
  }
  lseek(fd, 0, SEEK_SET);
  {
    ndsid::can::CandumpReader reader("/proc/self/fd/" + std::to_string(fd));
    std::vector<ndsid::can::CanFrame> frames(7);
    uint64_t read = 0;
    for (int guard = 0; guard < 1'000'000; ++guard) {
      const auto r = reader.Read(frames);
      read += r.count;
      if (r.state != ndsid::can::SourceState::kOk) break;
      for (size_t i = 0; i < r.count; ++i) {
        if (frames[i].len > ndsid::can::kMaxPayload || frames[i].bus >= reader.bus_names().size()) std::abort();
      }
    }
    const auto& c = reader.counters();
    if (c.frames != read || c.frames + c.malformed > reader.lines()) std::abort();
    const bool gzip_magic = bytes.size() >= 2 && bytes[0] == '\x1f' && bytes[1] == '\x8b';
    if (mode == 0 && !gzip_magic && !reader.io_error().empty()) std::abort();  // plain text: no read error
    if (mode == 1 && !reader.io_error().empty()) std::abort();  // a complete gzip stream reads cleanly
  }
  close(fd);
  return 0;
}
