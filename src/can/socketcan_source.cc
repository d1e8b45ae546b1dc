// SocketCanSource: a poll()/recvmmsg() read loop over one datagram fd, with reconnects.
#include "ndsid/can/socketcan_source.h"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/sock_diag.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cstring>
#include <ctime>

#include "can_logger.h"
#include "ndsid/can/error_frame.h"
#include "ndsid/common/error.h"
#include "socketcan_records.h"

namespace ndsid::can {

namespace {

constexpr int64_t kNsPerMs = 1'000'000;
#ifndef SO_MEMINFO
constexpr int SO_MEMINFO = 55;  // Linux >= 4.6
#endif

int64_t ClockNs(clockid_t clock) noexcept {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Best-effort options every fd gets (a CAN socket from OpenCanSocket has them already).
void EnableReceiveMetadata(int fd) noexcept {
  const int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
  setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
}

int CeilMs(int64_t ns) noexcept {
  if (ns <= 0) return 0;
  const int64_t ms = (ns + kNsPerMs - 1) / kNsPerMs;
  return ms > INT_MAX ? INT_MAX : static_cast<int>(ms);
}

void ValidateOptions(const SocketCanOptions& o, const std::string& name) {
  auto fail = [&name](const std::string& what) {
    throw Error("socketcan " + name + ": " + what);
  };
  if (o.reconnect_initial_ms <= 0) fail("reconnect_initial_ms must be > 0");
  if (o.reconnect_max_ms < o.reconnect_initial_ms) fail("reconnect_max_ms must be >= reconnect_initial_ms");
  if (o.error_log_interval_ms < 0) fail("error_log_interval_ms must be >= 0");
  for (const auto& f : o.ids) {
    if (f.id > (f.extended ? kExtendedIdMask : kStandardIdMask)) {
      fail("filter id " + std::to_string(f.id) + " exceeds " + (f.extended ? "29" : "11") + " bits");
    }
  }
}

}  // namespace

struct SocketCanSource::Impl {
  SocketCanOptions options;
  std::string description;
  std::vector<std::string> bus_names;
  OpenFn reopen;
  ClockFn clock;
  std::shared_ptr<spdlog::logger> log;

  int fd = -1;
  bool disconnect_unreported = false;
  int64_t next_attempt_ns = 0;
  int backoff_ms = 0;
  uint32_t last_drop_count = 0;
  SourceCounters counters;
  uint64_t fallback_timestamps = 0;
  int64_t last_timestamp_ns = INT64_MIN;
  int64_t next_error_log_ns = 0;
  uint64_t unlogged_error_frames = 0;

  std::array<std::array<uint8_t, CANFD_MTU>, kMaxBatch> records{};
  struct alignas(cmsghdr) ControlBuffer {
    char bytes[detail::kControlBytes];
  };
  std::array<ControlBuffer, kMaxBatch> controls{};
  std::array<iovec, kMaxBatch> iovs{};
  std::array<mmsghdr, kMaxBatch> messages{};

  int64_t Now() const noexcept {
    if (!clock) return ClockNs(CLOCK_MONOTONIC);
    try {
      return clock();
    } catch (...) {
      return ClockNs(CLOCK_MONOTONIC);
    }
  }
  void Disconnect(const char* what, int error) noexcept;
  bool TryReconnect(int64_t now) noexcept;
  // Receives one batch into out; `vanished` when the stream ended or the interface is gone.
  size_t Receive(std::span<CanFrame> out, bool& vanished) noexcept;
  void LogErrorFrame(const CanFrame& frame, int64_t now) noexcept;
  // The socket's cumulative drop count, from a record's SO_RXQ_OVFL or from SO_MEMINFO.
  void UpdateDrops(uint32_t total) noexcept;
  void QueryDrops() noexcept;
};

// SO_RXQ_OVFL stamps each record with the drop count at the time it was queued, so the drops
// of a burst show only on the next record queued after it; SO_MEMINFO reads the count now.
// Both are cumulative per socket: only a count ahead of the last one seen adds.
void SocketCanSource::Impl::UpdateDrops(uint32_t total) noexcept {
  const uint32_t delta = total - last_drop_count;
  if (delta == 0 || static_cast<int32_t>(delta) < 0) return;  // an older record's stamp
  counters.dropped += delta;
  last_drop_count = total;
}

void SocketCanSource::Impl::QueryDrops() noexcept {
  if (fd < 0) return;
  std::array<uint32_t, SK_MEMINFO_VARS> mem{};
  socklen_t size = sizeof mem;
  if (getsockopt(fd, SOL_SOCKET, SO_MEMINFO, mem.data(), &size) != 0 ||
      size < (SK_MEMINFO_DROPS + 1) * sizeof(uint32_t)) {
    return;
  }
  UpdateDrops(mem[SK_MEMINFO_DROPS]);
}

void SocketCanSource::Impl::Disconnect(const char* what, int error) noexcept {
  if (fd >= 0) close(fd);
  fd = -1;
  backoff_ms = options.reconnect_initial_ms;
  next_attempt_ns = Now() + backoff_ms * kNsPerMs;
  try {
    log->warn("{}: disconnected ({}{}{}); reopening in {} ms", description, what,
              error != 0 ? ": " : "", error != 0 ? std::strerror(error) : "", backoff_ms);
  } catch (...) {
  }
}

bool SocketCanSource::Impl::TryReconnect(int64_t now) noexcept {
  int new_fd = -1;
  int error = 0;
  if (reopen) {
    try {
      new_fd = reopen();
      error = errno;
    } catch (...) {
      new_fd = -1;
    }
  }
  if (new_fd >= 0) {
    fd = new_fd;
    EnableReceiveMetadata(fd);
    last_drop_count = 0;  // a new socket counts its drops from zero
    ++counters.reconnects;
    try {
      log->info("{}: reconnected", description);
    } catch (...) {
    }
    return true;
  }
  if (!reopen) {
    next_attempt_ns = INT64_MAX;  // nothing to retry with
    return false;
  }
  backoff_ms = std::min(backoff_ms * 2, options.reconnect_max_ms);
  next_attempt_ns = now + backoff_ms * kNsPerMs;
  try {
    log->debug("{}: reopen failed ({}); next attempt in {} ms", description, std::strerror(error), backoff_ms);
  } catch (...) {
  }
  return false;
}

void SocketCanSource::Impl::LogErrorFrame(const CanFrame& frame, int64_t now) noexcept {
  if (now < next_error_log_ns) {
    ++unlogged_error_frames;
    return;
  }
  next_error_log_ns = now + options.error_log_interval_ms * kNsPerMs;
  try {
    log->warn("{}: error frame: {}{}", description, DescribeErrorFrame(frame),
              unlogged_error_frames > 0
                  ? " (+" + std::to_string(unlogged_error_frames) + " not logged since the last)"
                  : std::string());
  } catch (...) {
  }
  unlogged_error_frames = 0;
}

size_t SocketCanSource::Impl::Receive(std::span<CanFrame> out, bool& vanished) noexcept {
  const size_t batch = std::min(out.size(), static_cast<size_t>(kMaxBatch));
  for (size_t i = 0; i < batch; ++i) {
    iovs[i] = {records[i].data(), records[i].size()};
    msghdr& h = messages[i].msg_hdr;
    h = msghdr{};
    h.msg_iov = &iovs[i];
    h.msg_iovlen = 1;
    h.msg_control = controls[i].bytes;
    h.msg_controllen = sizeof controls[i].bytes;
    messages[i].msg_len = 0;
  }
  const int n = recvmmsg(fd, messages.data(), static_cast<unsigned>(batch), MSG_DONTWAIT, nullptr);
  if (n < 0) {
    const int error = errno;
    if (error == EAGAIN || error == EWOULDBLOCK || error == EINTR || error == ENOBUFS) return 0;
    vanished = true;
    Disconnect("read", error);
    return 0;
  }
  size_t count = 0;
  const int64_t now = Now();
  for (int i = 0; i < n; ++i) {
    const mmsghdr& m = messages[i];
    if (m.msg_len == 0) {  // end of stream (a CAN socket never delivers empty records)
      vanished = true;
      Disconnect("end of stream", 0);
      break;
    }
    CanFrame& frame = out[count];
    const auto verdict = (m.msg_hdr.msg_flags & MSG_TRUNC) != 0
                             ? detail::RecordVerdict::kMalformed
                             : detail::DecodeRecord(records[i].data(), m.msg_len, frame);
    const detail::Control control = detail::ReadControl(m.msg_hdr);
    if (control.has_drop_count) UpdateDrops(control.drop_count);
    if (verdict == detail::RecordVerdict::kMalformed) {
      ++counters.malformed;
      continue;
    }
    if (control.has_timestamp) {
      frame.timestamp_ns = control.timestamp_ns;
    } else {
      frame.timestamp_ns = ClockNs(CLOCK_REALTIME);
      ++fallback_timestamps;
    }
    frame.bus = 0;
    if (frame.timestamp_ns < last_timestamp_ns) ++counters.time_backwards;
    last_timestamp_ns = frame.timestamp_ns;
    if (verdict == detail::RecordVerdict::kError) {
      ++counters.error_frames;
      LogErrorFrame(frame, now);
    }
    ++counters.frames;
    ++count;
  }
  if (static_cast<size_t>(n) < batch) QueryDrops();  // queue drained: drops since the last record
  return count;
}

SocketCanSource::SocketCanSource(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

SocketCanSource::SocketCanSource(SocketCanOptions options) {
  ValidateOptions(options, options.interface);
  std::string error;
  const int fd = OpenCanSocket(options, error);
  const bool down = fd < 0 && errno == ENETDOWN;  // exists but is down: wait for it to come up
  if (fd < 0 && !down) throw Error("socketcan " + options.interface + ": " + error);
  impl_ = std::make_unique<Impl>();
  impl_->options = options;
  impl_->description = "socketcan " + options.interface;
  impl_->bus_names = {options.interface};
  impl_->log = CanLogger();
  impl_->fd = fd;
  impl_->reopen = [options, log = impl_->log]() {
    std::string why;
    const int new_fd = OpenCanSocket(options, why);
    const int saved = errno;
    if (new_fd < 0) log->debug("socketcan {}: {}", options.interface, why);
    errno = saved;
    return new_fd;
  };
  if (down) {
    impl_->backoff_ms = options.reconnect_initial_ms;
    impl_->next_attempt_ns = impl_->Now() + impl_->backoff_ms * kNsPerMs;
    impl_->log->warn("socketcan {}: {}; waiting for it to come up", options.interface, error);
  }
}

std::unique_ptr<SocketCanSource> SocketCanSource::Adopt(int fd, std::string bus_name, OpenFn reopen,
                                                        SocketCanOptions options, ClockFn clock) {
  if (fd < 0 || fcntl(fd, F_GETFD) == -1) {
    throw Error("socketcan " + bus_name + ": adopted file descriptor " + std::to_string(fd) + " is not open");
  }
  ValidateOptions(options, bus_name);
  auto impl = std::make_unique<Impl>();
  impl->options = std::move(options);
  impl->description = "socketcan " + bus_name + " (fd)";
  impl->bus_names = {std::move(bus_name)};
  impl->reopen = std::move(reopen);
  impl->clock = std::move(clock);
  impl->log = CanLogger();
  impl->fd = fd;
  EnableReceiveMetadata(fd);
  return std::unique_ptr<SocketCanSource>(new SocketCanSource(std::move(impl)));
}

SocketCanSource::~SocketCanSource() {
  if (impl_ && impl_->fd >= 0) close(impl_->fd);
}

ReadResult SocketCanSource::Read(std::span<CanFrame> out, int timeout_ms) noexcept {
  Impl& s = *impl_;
  if (s.disconnect_unreported) {
    s.disconnect_unreported = false;
    return {0, SourceState::kDisconnected};
  }
  if (out.empty()) return {0, s.fd >= 0 ? SourceState::kTimeout : SourceState::kDisconnected};
  const int64_t deadline = timeout_ms < 0 ? INT64_MAX : s.Now() + timeout_ms * kNsPerMs;
  for (;;) {
    const int64_t now = s.Now();
    if (s.fd < 0) {
      if (now >= s.next_attempt_ns && s.TryReconnect(now)) continue;
      if (now >= deadline) return {0, SourceState::kDisconnected};
      const int64_t wake = std::min(deadline, s.next_attempt_ns);
      poll(nullptr, 0, CeilMs(wake - now));  // sleep until the next attempt or the deadline
      if (wake == deadline) {
        if (s.Now() >= s.next_attempt_ns && s.TryReconnect(s.Now())) continue;
        return {0, SourceState::kDisconnected};
      }
      continue;
    }
    pollfd p{s.fd, POLLIN, 0};
    const int ready = poll(&p, 1, deadline == INT64_MAX ? -1 : CeilMs(deadline - now));
    if (ready < 0) {
      if (errno == EINTR) continue;
      s.Disconnect("poll", errno);
      return {0, SourceState::kDisconnected};
    }
    if (ready == 0) {
      s.QueryDrops();
      return {0, SourceState::kTimeout};
    }
    if (p.revents & POLLIN) {  // drain data first, even when POLLHUP/POLLERR are also set
      bool vanished = false;
      const size_t count = s.Receive(out, vanished);
      if (vanished) {
        if (count == 0) return {0, SourceState::kDisconnected};
        s.disconnect_unreported = true;
      }
      if (count > 0) return {count, SourceState::kOk};
      continue;  // only malformed records, or nothing after all
    }
    if (p.revents & (POLLERR | POLLHUP | POLLNVAL)) {
      int error = 0;
      socklen_t size = sizeof error;
      if ((p.revents & POLLERR) && !(p.revents & (POLLHUP | POLLNVAL)) &&
          getsockopt(s.fd, SOL_SOCKET, SO_ERROR, &error, &size) == 0 && error != 0 &&
          !detail::IsDisconnectErrno(error)) {
        continue;  // a transient socket error, now cleared (e.g. ENOBUFS)
      }
      s.Disconnect((p.revents & POLLHUP) ? "hang-up" : "socket error", error);
      return {0, SourceState::kDisconnected};
    }
  }
}

const SourceCounters& SocketCanSource::counters() const noexcept { return impl_->counters; }
const std::vector<std::string>& SocketCanSource::bus_names() const noexcept { return impl_->bus_names; }
std::string SocketCanSource::Describe() const { return impl_->description; }
bool SocketCanSource::connected() const noexcept { return impl_->fd >= 0; }
uint64_t SocketCanSource::fallback_timestamps() const noexcept { return impl_->fallback_timestamps; }

}  // namespace ndsid::can
