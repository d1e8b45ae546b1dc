// SocketCanSource on a real virtual CAN interface. Needs AF_CAN and a vcan0 interface (or root
// to create one with `ip link add dev vcan0 type vcan`); reported SKIPPED with the reason
// otherwise. Where it runs it checks what the socketpair tests cannot: the kernel filters,
// CAN FD on a real socket, and an interface that is deleted and re-created.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>

#include "ndsid/can/socketcan_source.h"

namespace ndsid::can {
namespace {

constexpr const char* kInterface = "vcan0";

bool RunShell(const std::string& command) { return std::system((command + " >/dev/null 2>&1").c_str()) == 0; }

bool CreateVcan() {
  return RunShell(std::string("ip link add dev ") + kInterface + " type vcan") &&
         RunShell(std::string("ip link set up ") + kInterface);
}

int OpenSender() {
  const int fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  const int one = 1;
  setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &one, sizeof one);
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(if_nametoindex(kInterface));
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

std::vector<CanFrame> ReadFor(SocketCanSource& source, int ms) {
  std::vector<CanFrame> all;
  std::vector<CanFrame> out(16);
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (std::chrono::steady_clock::now() < end) {
    const ReadResult r = source.Read(out, 20);
    all.insert(all.end(), out.begin(), out.begin() + static_cast<ptrdiff_t>(r.count));
  }
  return all;
}

TEST(Vcan, KernelFiltersFdFramesAndInterfaceRecreation) {
  const int probe = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (probe < 0) GTEST_SKIP() << "no AF_CAN on this host: socket(PF_CAN): " << std::strerror(errno);
  close(probe);
  bool created = false;
  if (if_nametoindex(kInterface) == 0) {
    if (!CreateVcan()) GTEST_SKIP() << "no " << kInterface << " and `ip link add dev vcan0 type vcan` failed (needs root and the vcan module)";
    created = true;
  }
  SocketCanOptions options;
  options.interface = kInterface;
  options.ids = {{0x123, false}, {0x18FEF100, true}};
  options.reconnect_initial_ms = 20;
  options.reconnect_max_ms = 100;
  SocketCanSource source(options);
  const int sender = OpenSender();
  ASSERT_GE(sender, 0);
  auto send_classic = [&](canid_t id) {
    can_frame f{};
    f.can_id = id;
    f.can_dlc = 2;
    f.data[0] = 0xAB;
    ASSERT_EQ(write(sender, &f, sizeof f), static_cast<ssize_t>(CAN_MTU));
  };
  send_classic(0x123);
  send_classic(0x124);                        // not in the filter
  send_classic(0x123 | CAN_EFF_FLAG);         // extended 0x123 is a different id
  send_classic(0x18FEF100 | CAN_EFF_FLAG);
  canfd_frame fd{};
  fd.can_id = 0x123;
  fd.flags = CANFD_BRS;
  fd.len = 32;
  fd.data[31] = 0x5A;
  ASSERT_EQ(write(sender, &fd, sizeof fd), static_cast<ssize_t>(CANFD_MTU));

  const auto frames = ReadFor(source, 300);
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].id, 0x123u);
  EXPECT_FALSE(frames[0].extended());
  EXPECT_EQ(frames[1].id, 0x18FEF100u);
  EXPECT_TRUE(frames[1].extended());
  EXPECT_TRUE(frames[2].fd());
  EXPECT_EQ(frames[2].len, 32);
  EXPECT_EQ(frames[2].data[31], 0x5A);
  EXPECT_EQ(source.fallback_timestamps(), 0u);
  close(sender);

  if (!created) {
    GTEST_SKIP() << kInterface << " existed before the test; not deleting it to test reconnects";
  }
  ASSERT_TRUE(RunShell(std::string("ip link del dev ") + kInterface));
  std::vector<CanFrame> out(16);
  ReadResult r{};
  for (int i = 0; i < 50 && r.state != SourceState::kDisconnected; ++i) r = source.Read(out, 20);
  EXPECT_EQ(r.state, SourceState::kDisconnected);
  ASSERT_TRUE(CreateVcan());
  ReadFor(source, 500);
  EXPECT_TRUE(source.connected());
  EXPECT_EQ(source.counters().reconnects, 1u);
  RunShell(std::string("ip link del dev ") + kInterface);
}

}  // namespace
}  // namespace ndsid::can
