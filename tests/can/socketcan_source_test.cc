// SocketCanSource's read loop, driven through an AF_UNIX SOCK_SEQPACKET socketpair that carries
// struct can_frame / struct canfd_frame records (this machine has no AF_CAN), plus the pure
// record and control-message helpers.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <ctime>

#include "ndsid/can/socketcan_source.h"
#include "ndsid/common/error.h"
#include "socketcan_records.h"

namespace ndsid::can {
namespace {

int64_t RealtimeNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

struct Pair {
  int source = -1;  // handed to SocketCanSource
  int peer = -1;    // the test writes records here
  Pair() {
    int fds[2];
    EXPECT_EQ(socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds), 0);
    source = fds[0];
    peer = fds[1];
  }
  ~Pair() { ClosePeer(); }
  void ClosePeer() {
    if (peer >= 0) close(peer);
    peer = -1;
  }
};

void SendClassic(int fd, canid_t id, std::initializer_list<uint8_t> data) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = static_cast<uint8_t>(data.size());
  std::copy(data.begin(), data.end(), f.data);
  ASSERT_EQ(send(fd, &f, sizeof f, 0), static_cast<ssize_t>(CAN_MTU));
}

void SendFd(int fd, canid_t id, uint8_t flags, int len, uint8_t fill) {
  canfd_frame f{};
  f.can_id = id;
  f.flags = flags;
  f.len = static_cast<uint8_t>(len);
  for (int i = 0; i < len; ++i) f.data[i] = static_cast<uint8_t>(fill + i);
  ASSERT_EQ(send(fd, &f, sizeof f, 0), static_cast<ssize_t>(CANFD_MTU));
}

SocketCanOptions FastReconnect() {
  SocketCanOptions o;
  o.reconnect_initial_ms = 10;
  o.reconnect_max_ms = 40;
  return o;
}

TEST(SocketCanSource, DeliversClassicRemoteAndFdFramesIntact) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "vcan0", {});
  SendClassic(pair.peer, 0x123, {0xDE, 0xAD, 0xBE, 0xEF});
  SendClassic(pair.peer, 0x18FEF100 | CAN_EFF_FLAG, {1, 2, 3, 4, 5, 6, 7, 8});
  SendClassic(pair.peer, 0x7FF | CAN_RTR_FLAG, {0, 0, 0});
  SendFd(pair.peer, 0x456, CANFD_BRS | CANFD_ESI, 64, 0x10);
  SendFd(pair.peer, 0x1ABCDEF0 | CAN_EFF_FLAG, 0, 12, 0x80);
  const int64_t before = RealtimeNs();
  std::vector<CanFrame> out(16);
  const ReadResult r = source->Read(out, 1000);
  ASSERT_EQ(r.state, SourceState::kOk);
  ASSERT_EQ(r.count, 5u);
  EXPECT_EQ(out[0].id, 0x123u);
  EXPECT_EQ(out[0].flags, 0);
  EXPECT_EQ(out[0].len, 4);
  EXPECT_EQ(out[0].data[3], 0xEF);
  EXPECT_EQ(out[1].id, 0x18FEF100u);
  EXPECT_EQ(out[1].flags, kFlagExtended);
  EXPECT_EQ(out[1].data[7], 8);
  EXPECT_EQ(out[2].flags, kFlagRemote);
  EXPECT_EQ(out[2].len, 3) << "remote frames keep the requested DLC";
  EXPECT_EQ(out[3].flags, kFlagFd | kFlagFdBrs | kFlagFdEsi);
  EXPECT_EQ(out[3].len, 64);
  EXPECT_EQ(out[3].data[63], 0x10 + 63);
  EXPECT_EQ(out[4].flags, kFlagFd | kFlagExtended);
  EXPECT_EQ(out[4].id, 0x1ABCDEF0u);
  EXPECT_EQ(out[4].len, 12);
  for (size_t i = 0; i < r.count; ++i) {
    EXPECT_EQ(out[i].bus, 0);
    EXPECT_LE(out[i].timestamp_ns, RealtimeNs());
    EXPECT_GT(out[i].timestamp_ns, before - 5'000'000'000) << "a kernel receive time, not zero";
  }
  EXPECT_EQ(source->fallback_timestamps(), 0u) << "AF_UNIX sockets deliver SO_TIMESTAMPNS";
  EXPECT_EQ(source->counters().frames, 5u);
  EXPECT_EQ(source->bus_names(), std::vector<std::string>{"vcan0"});
}

TEST(SocketCanSource, FallsBackToRealtimeClockWithoutKernelTimestamp) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "vcan0", {});
  const int zero = 0;
  ASSERT_EQ(setsockopt(pair.source, SOL_SOCKET, SO_TIMESTAMPNS, &zero, sizeof zero), 0);
  const int64_t before = RealtimeNs();
  SendClassic(pair.peer, 0x100, {1});
  std::vector<CanFrame> out(4);
  ASSERT_EQ(source->Read(out, 1000).count, 1u);
  EXPECT_GE(out[0].timestamp_ns, before);
  EXPECT_LE(out[0].timestamp_ns, RealtimeNs());
  EXPECT_EQ(source->fallback_timestamps(), 1u);
}

TEST(SocketCanSource, BatchesAreLimitedByOutputSizeAndMaxBatchAndKeepOrder) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "vcan0", {});
  for (canid_t id = 0; id < 200; ++id) SendClassic(pair.peer, id, {static_cast<uint8_t>(id)});
  std::vector<CanFrame> small(50);
  ReadResult r = source->Read(small, 1000);
  ASSERT_EQ(r.count, 50u);
  EXPECT_EQ(small[49].id, 49u);
  std::vector<CanFrame> large(1000);
  r = source->Read(large, 1000);
  ASSERT_EQ(r.count, static_cast<size_t>(SocketCanSource::kMaxBatch));
  EXPECT_EQ(large[0].id, 50u);
  uint32_t next = 50 + SocketCanSource::kMaxBatch;
  while (next < 200) {
    r = source->Read(large, 1000);
    ASSERT_EQ(r.state, SourceState::kOk);
    for (size_t i = 0; i < r.count; ++i) ASSERT_EQ(large[i].id, next++);
  }
  EXPECT_EQ(source->counters().frames, 200u);
  EXPECT_EQ(source->Read(large, 0).state, SourceState::kTimeout);
}

TEST(SocketCanSource, ErrorFramesAreDeliveredFlaggedAndCounted) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "can0", {});
  SendClassic(pair.peer, CAN_ERR_FLAG | CAN_ERR_BUSOFF, {0, 0, 0, 0, 0, 0, 0, 0});
  SendClassic(pair.peer, CAN_ERR_FLAG | CAN_ERR_CRTL, {0, CAN_ERR_CRTL_RX_PASSIVE, 0, 0, 0, 0, 0, 0});
  SendClassic(pair.peer, 0x321, {9});
  std::vector<CanFrame> out(8);
  const ReadResult r = source->Read(out, 1000);
  ASSERT_EQ(r.count, 3u);
  EXPECT_TRUE(out[0].error());
  EXPECT_EQ(out[0].id, static_cast<uint32_t>(CAN_ERR_BUSOFF));
  EXPECT_FALSE(out[0].extended());
  EXPECT_TRUE(out[1].error());
  EXPECT_EQ(out[1].data[1], CAN_ERR_CRTL_RX_PASSIVE);
  EXPECT_FALSE(out[2].error());
  EXPECT_EQ(source->counters().error_frames, 2u);
  EXPECT_EQ(source->counters().frames, 3u);
}

TEST(SocketCanSource, RecordsOfWrongSizeAreCountedMalformedNotDelivered) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "can0", {});
  const char junk[20] = {};
  ASSERT_EQ(send(pair.peer, junk, sizeof junk, 0), 20);
  const char big[100] = {};
  ASSERT_EQ(send(pair.peer, big, sizeof big, 0), 100);  // truncated to 72 by the receive buffer
  can_frame too_long{};
  too_long.can_id = 0x10;
  too_long.can_dlc = 9;
  ASSERT_EQ(send(pair.peer, &too_long, sizeof too_long, 0), 16);
  SendClassic(pair.peer, 0x42, {1, 2});
  std::vector<CanFrame> out(8);
  const ReadResult r = source->Read(out, 1000);
  ASSERT_EQ(r.count, 1u);
  EXPECT_EQ(out[0].id, 0x42u);
  EXPECT_EQ(source->counters().malformed, 3u);
}

TEST(SocketCanSource, TimeoutReturnsTimeoutAfterWaiting) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "can0", {});
  std::vector<CanFrame> out(8);
  const auto start = std::chrono::steady_clock::now();
  const ReadResult r = source->Read(out, 50);
  const auto waited = std::chrono::steady_clock::now() - start;
  EXPECT_EQ(r.state, SourceState::kTimeout);
  EXPECT_EQ(r.count, 0u);
  EXPECT_GE(waited, std::chrono::milliseconds(45));
  EXPECT_LT(waited, std::chrono::seconds(5));
}

TEST(SocketCanSource, FramesBeforeHangUpAreDeliveredThenDisconnectIsReported) {
  Pair pair;
  auto source = SocketCanSource::Adopt(pair.source, "can0", {}, FastReconnect());
  SendClassic(pair.peer, 0x1, {1});
  SendClassic(pair.peer, 0x2, {2});
  pair.ClosePeer();
  std::vector<CanFrame> out(8);
  ReadResult r = source->Read(out, 1000);
  EXPECT_EQ(r.state, SourceState::kOk);
  EXPECT_EQ(r.count, 2u);
  r = source->Read(out, 0);
  EXPECT_EQ(r.state, SourceState::kDisconnected);
  EXPECT_EQ(r.count, 0u);
  EXPECT_FALSE(source->connected());
  r = source->Read(out, 20);
  EXPECT_EQ(r.state, SourceState::kDisconnected) << "no reopen callback: stays disconnected";
  EXPECT_EQ(source->counters().reconnects, 0u);
}

TEST(SocketCanSource, VanishedPeerIsReopenedThroughCallbackAndCounted) {
  Pair first;
  Pair second;
  int reopen_calls = 0;
  auto reopen = [&]() {
    ++reopen_calls;
    if (reopen_calls < 2) {  // the interface is still gone on the first attempt
      errno = ENODEV;
      return -1;
    }
    const int fd = second.source;
    second.source = -1;
    return fd;
  };
  auto source = SocketCanSource::Adopt(first.source, "can0", reopen, FastReconnect());
  std::vector<CanFrame> out(8);
  first.ClosePeer();
  ReadResult r = source->Read(out, 0);
  ASSERT_EQ(r.state, SourceState::kDisconnected);
  SendClassic(second.peer, 0x77, {7});
  const auto start = std::chrono::steady_clock::now();
  while (r.state != SourceState::kOk && std::chrono::steady_clock::now() - start < std::chrono::seconds(5)) {
    r = source->Read(out, 25);
    if (r.state != SourceState::kOk) {
      EXPECT_EQ(r.state, reopen_calls >= 2 ? SourceState::kTimeout : SourceState::kDisconnected);
    }
  }
  ASSERT_EQ(r.state, SourceState::kOk);
  EXPECT_EQ(out[0].id, 0x77u);
  EXPECT_EQ(reopen_calls, 2);
  EXPECT_EQ(source->counters().reconnects, 1u);
  EXPECT_TRUE(source->connected());
  // The new connection vanishes too: detected and reconnected again the same way.
  second.ClosePeer();
  EXPECT_EQ(source->Read(out, 100).state, SourceState::kDisconnected);
}

TEST(SocketCanSource, ReadWhileDisconnectedNeverBlocksPastTimeout) {
  Pair pair;
  SocketCanOptions options;
  options.reconnect_initial_ms = 10'000;  // next attempt far beyond the timeout
  options.reconnect_max_ms = 10'000;
  int calls = 0;
  auto source = SocketCanSource::Adopt(pair.source, "can0", [&] { return ++calls, -1; }, options);
  pair.ClosePeer();
  std::vector<CanFrame> out(8);
  ASSERT_EQ(source->Read(out, 0).state, SourceState::kDisconnected);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(source->Read(out, 60).state, SourceState::kDisconnected);
  const auto waited = std::chrono::steady_clock::now() - start;
  EXPECT_GE(waited, std::chrono::milliseconds(55)) << "waits out the timeout";
  EXPECT_LT(waited, std::chrono::seconds(3)) << "does not wait for the 10 s back-off";
  EXPECT_EQ(calls, 0);
}

// With an injected clock: attempts at 100 ms, then back-off doubling 200, 400, ... capped at 5 s.
TEST(SocketCanSource, ReconnectBackOffDoublesFrom100MsUpTo5s) {
  Pair pair;
  int64_t now_ns = 0;
  std::vector<int64_t> attempts_ms;
  auto source = SocketCanSource::Adopt(
      pair.source, "can0",
      [&] {
        attempts_ms.push_back(now_ns / 1'000'000);
        errno = ENODEV;
        return -1;
      },
      SocketCanOptions{}, [&] { return now_ns; });
  pair.ClosePeer();
  std::vector<CanFrame> out(8);
  ASSERT_EQ(source->Read(out, 0).state, SourceState::kDisconnected);
  for (; now_ns <= 17'000'000'000; now_ns += 10'000'000) {
    ASSERT_EQ(source->Read(out, 0).state, SourceState::kDisconnected);
  }
  const std::vector<int64_t> expected = {100, 300, 700, 1500, 3100, 6300, 11300, 16300};
  EXPECT_EQ(attempts_ms, expected);
  EXPECT_EQ(source->counters().reconnects, 0u);
}

// The kernel's own drop counter on a real datagram socket (UDP on loopback counts receive-queue
// overflows the way CAN_RAW does): SO_RXQ_OVFL stamps a record with the drops before it was
// queued, so a burst whose drops come after the last queued record shows only through SO_MEMINFO.
TEST(SocketCanSource, DropsOfABurstAreCountedAlsoWithoutALaterRecord) {
  const int rx = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  const int tx = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(rx, 0);
  ASSERT_GE(tx, 0);
  const int small = 4096;  // the kernel doubles it: a few dozen records fit
  ASSERT_EQ(setsockopt(rx, SOL_SOCKET, SO_RCVBUF, &small, sizeof small), 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(rx, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  socklen_t size = sizeof address;
  ASSERT_EQ(getsockname(rx, reinterpret_cast<sockaddr*>(&address), &size), 0);
  auto source = SocketCanSource::Adopt(rx, "udp", {});
  can_frame raw{};
  raw.can_id = 0x123;
  raw.len = 8;
  uint64_t sent = 0;
  for (int i = 0; i < 2000; ++i) {
    if (sendto(tx, &raw, sizeof raw, 0, reinterpret_cast<sockaddr*>(&address), sizeof address) == sizeof raw) ++sent;
  }
  close(tx);
  std::vector<CanFrame> out(64);
  uint64_t read = 0;
  for (ReadResult r = source->Read(out, 100); r.state == SourceState::kOk; r = source->Read(out, 100)) read += r.count;
  EXPECT_EQ(sent, 2000u);
  EXPECT_GT(read, 0u);
  EXPECT_LT(read, sent) << "the burst must overflow the small receive queue";
  EXPECT_EQ(source->counters().frames, read);
  EXPECT_EQ(read + source->counters().dropped, sent) << "every frame read or counted as dropped";
}

TEST(SocketCanSource, AdoptingClosedFdThrowsNamingTheBus) {
  try {
    SocketCanSource::Adopt(-1, "can7", {});
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("can7"), std::string::npos) << e.what();
  }
}

TEST(SocketCanSource, InvalidBackOffOptionsAreRejectedAtConstruction) {
  Pair pair;
  SocketCanOptions options;
  options.reconnect_max_ms = 50;  // below the initial 100 ms
  EXPECT_THROW(SocketCanSource::Adopt(pair.source, "can0", {}, options), Error);
  close(pair.source);
}

TEST(SocketCanSource, OpeningMissingInterfaceThrowsNamingIt) {
  SocketCanOptions options;
  options.interface = "ndsidnone0";
  try {
    SocketCanSource source(options);
    FAIL() << "no exception";
  } catch (const Error& e) {  // no AF_CAN here, or no such interface on a CAN-capable host
    EXPECT_NE(std::string(e.what()).find("ndsidnone0"), std::string::npos) << e.what();
  }
}

TEST(SocketCanRecords, RejectsLengthsTheFrameTypeCannotHave) {
  CanFrame frame;
  can_frame classic{};
  classic.can_dlc = 9;
  EXPECT_EQ(detail::DecodeRecord(reinterpret_cast<uint8_t*>(&classic), CAN_MTU, frame),
            detail::RecordVerdict::kMalformed);
  canfd_frame fd{};
  fd.len = 13;
  EXPECT_EQ(detail::DecodeRecord(reinterpret_cast<uint8_t*>(&fd), CANFD_MTU, frame),
            detail::RecordVerdict::kMalformed);
  fd.len = 48;
  fd.can_id = 0x7FF;
  EXPECT_EQ(detail::DecodeRecord(reinterpret_cast<uint8_t*>(&fd), CANFD_MTU, frame),
            detail::RecordVerdict::kFrame);
  fd.can_id = 0x7FF | CAN_RTR_FLAG;
  EXPECT_EQ(detail::DecodeRecord(reinterpret_cast<uint8_t*>(&fd), CANFD_MTU, frame),
            detail::RecordVerdict::kMalformed) << "CAN FD has no remote frames";
  EXPECT_EQ(detail::DecodeRecord(reinterpret_cast<uint8_t*>(&fd), 17, frame),
            detail::RecordVerdict::kMalformed);
}

TEST(SocketCanRecords, ControlMessagesGiveTimestampAndDropCounter) {
  alignas(cmsghdr) char buffer[detail::kControlBytes] = {};
  msghdr message{};
  message.msg_control = buffer;
  message.msg_controllen = sizeof buffer;
  cmsghdr* c = CMSG_FIRSTHDR(&message);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SO_TIMESTAMPNS;
  c->cmsg_len = CMSG_LEN(sizeof(timespec));
  const timespec ts{1700000000, 123456789};
  std::memcpy(CMSG_DATA(c), &ts, sizeof ts);
  c = CMSG_NXTHDR(&message, c);
  ASSERT_NE(c, nullptr);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SO_RXQ_OVFL;
  c->cmsg_len = CMSG_LEN(sizeof(uint32_t));
  const uint32_t drops = 42;
  std::memcpy(CMSG_DATA(c), &drops, sizeof drops);
  message.msg_controllen = CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(uint32_t));
  const detail::Control control = detail::ReadControl(message);
  EXPECT_TRUE(control.has_timestamp);
  EXPECT_EQ(control.timestamp_ns, 1700000000123456789);
  EXPECT_TRUE(control.has_drop_count);
  EXPECT_EQ(control.drop_count, 42u);
}

TEST(SocketCanRecords, VanishedInterfaceErrnosMeanDisconnectTransientOnesDoNot) {
  EXPECT_TRUE(detail::IsDisconnectErrno(ENODEV));
  EXPECT_TRUE(detail::IsDisconnectErrno(ENETDOWN));
  EXPECT_TRUE(detail::IsDisconnectErrno(ENXIO));
  EXPECT_FALSE(detail::IsDisconnectErrno(EAGAIN));
  EXPECT_FALSE(detail::IsDisconnectErrno(ENOBUFS));
  EXPECT_FALSE(detail::IsDisconnectErrno(EINTR));
}

}  // namespace
}  // namespace ndsid::can
