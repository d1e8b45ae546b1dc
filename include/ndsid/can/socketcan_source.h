// Live frames from a SocketCAN raw socket (PF_CAN, SOCK_RAW, CAN_RAW), following candump.c:
// kernel id filters, CAN FD frames, kernel receive timestamps (SO_TIMESTAMPNS), the kernel's
// drop counter (SO_RXQ_OVFL), error frames (CAN_RAW_ERR_FILTER), batched reads (recvmmsg).
//
// The read loop works on any datagram file descriptor that carries `struct can_frame` (16 B)
// and `struct canfd_frame` (72 B) records, so it is tested through an AF_UNIX SOCK_SEQPACKET
// socketpair on machines without AF_CAN (see Adopt()).
//
// When the interface vanishes (ENODEV/ENETDOWN/ENXIO, POLLERR/POLLHUP, end of stream) the
// source closes the socket, reports kDisconnected once, and then tries to reopen it inside
// later Read() calls with exponential back-off; Read() never blocks longer than its timeout.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ndsid/can/frame_source.h"

namespace ndsid::can {

struct CanIdFilter {
  uint32_t id = 0;        // 11- or 29-bit identifier
  bool extended = false;  // 29-bit
};

struct SocketCanOptions {
  std::string interface = "can0";  // network interface name (IFNAMSIZ-1 = 15 chars at most)
  // Data frames to receive; empty = all. More than 512 (CAN_RAW_FILTER_MAX) ids: all.
  std::vector<CanIdFilter> ids;
  bool fd_frames = true;  // enable CAN_RAW_FD_FRAMES (a warning, not an error, if unsupported)
  // CAN_RAW_ERR_FILTER class mask (CAN_ERR_* bits of linux/can/error.h). The default keeps
  // everything except CAN_ERR_BUSERROR, which can flood at one frame per bit error.
  uint32_t error_mask = 0x1FFFFF7Fu;
  int reconnect_initial_ms = 100;   // first reopen attempt this long after a disconnect
  int reconnect_max_ms = 5000;      // back-off doubles up to this
  int error_log_interval_ms = 1000; // at most one error-frame log line per interval
  int receive_buffer_bytes = 0;     // SO_RCVBUF; 0 = kernel default
};

class SocketCanSource final : public FrameSource {
 public:
  // Returns a new open fd, or -1 with errno set. Called for reconnects.
  using OpenFn = std::function<int()>;
  // Monotonic time in ns; drives the back-off and the log rate limit (not frame times).
  using ClockFn = std::function<int64_t()>;

  static constexpr int kMaxBatch = 64;  // records per recvmmsg call

  // Opens and binds a raw CAN socket on options.interface. Throws ndsid::Error naming the
  // interface when it cannot (no such interface, no AF_CAN, bind failure).
  explicit SocketCanSource(SocketCanOptions options);

  // Takes ownership of an open datagram fd (records as above) named `bus_name`; `reopen` is
  // called after a disconnect (empty: stay disconnected). `clock` defaults to CLOCK_MONOTONIC.
  // Throws ndsid::Error when `fd` is invalid.
  static std::unique_ptr<SocketCanSource> Adopt(int fd, std::string bus_name, OpenFn reopen,
                                                SocketCanOptions options = {},
                                                ClockFn clock = {});

  ~SocketCanSource() override;
  SocketCanSource(const SocketCanSource&) = delete;
  SocketCanSource& operator=(const SocketCanSource&) = delete;

  // Waits up to timeout_ms (< 0: forever) for frames. kOk: count > 0 frames; kTimeout: none
  // arrived; kDisconnected: the interface is gone (reported once at detection and then on
  // every call until a reopen succeeds). Error frames are delivered with kFlagError and
  // counted in error_frames. Any state other than kOk comes with count == 0.
  ReadResult Read(std::span<CanFrame> out, int timeout_ms) noexcept override;
  const SourceCounters& counters() const noexcept override;
  const std::vector<std::string>& bus_names() const noexcept override;
  std::string Describe() const override;

  bool connected() const noexcept;
  // Frames delivered with the CLOCK_REALTIME fallback because no kernel timestamp came with them.
  uint64_t fallback_timestamps() const noexcept;

 private:
  struct Impl;
  explicit SocketCanSource(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// Opens, configures and binds a raw CAN socket as SocketCanSource does (the socket setup
// order of candump.c). Returns the fd, or -1 with `error` saying which step failed.
int OpenCanSocket(const SocketCanOptions& options, std::string& error) noexcept;

}  // namespace ndsid::can
