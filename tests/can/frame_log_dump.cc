// Prints every frame of a log read through can::OpenFrameLog, for the Python cross-checks
// (log_formats_crosscheck.py): one line per frame
//   <timestamp_ns> <bus name> <id hex> <flags> <len> <data hex or ->
// then "# format=... frames=... malformed=... skipped=... error_frames=... io_error=..." and
// "# fraction_read first=F last=F monotonic=0|1" (FrameLog::fraction_read after each batch).
// Exit 0, 65 when reading stopped early (io_error), 78 for an unsupported format.
#include <cinttypes>
#include <cstdio>
#include <exception>
#include <vector>

#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s LOG\n", argv[0]);
    return 2;
  }
  try {
    const auto log = ndsid::can::OpenFrameLog(argv[1]);
    std::vector<ndsid::can::CanFrame> frames(512);
    double first_fraction = -2, last_fraction = -2;
    bool monotonic = true;
    for (;;) {
      const auto r = log->Read(frames, 0);
      const double fraction = log->fraction_read();
      if (first_fraction == -2) first_fraction = fraction;
      monotonic = monotonic && fraction >= last_fraction;
      last_fraction = fraction;
      for (size_t i = 0; i < r.count; ++i) {
        const auto& f = frames[i];
        char data[2 * ndsid::can::kMaxPayload + 2] = "-";
        for (int k = 0; k < f.len; ++k) std::snprintf(data + 2 * k, 3, "%02X", f.data[static_cast<size_t>(k)]);
        std::printf("%" PRId64 " %s %X %u %u %s\n", f.timestamp_ns, log->bus_names()[f.bus].c_str(), f.id,
                    unsigned{f.flags}, unsigned{f.len}, data);
      }
      if (r.state == ndsid::can::SourceState::kEnd) break;
    }
    const auto& c = log->counters();
    std::printf("# format=%s frames=%" PRIu64 " malformed=%" PRIu64 " skipped=%" PRIu64 " error_frames=%" PRIu64
                " io_error=%s\n",
                ndsid::can::LogFormatName(log->format()), c.frames, c.malformed, log->skipped_records(), c.error_frames,
                log->io_error().empty() ? "-" : log->io_error().c_str());
    for (const auto& m : log->first_malformed()) std::printf("# malformed %s\n", log->Locate(m).c_str());
    std::printf("# fraction_read first=%.6f last=%.6f monotonic=%d\n", first_fraction, last_fraction, monotonic ? 1 : 0);
    return log->io_error().empty() ? 0 : 65;
  } catch (const ndsid::ConfigError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 78;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
