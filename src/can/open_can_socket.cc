// Raw CAN socket set-up in the order of can-utils' candump.c: socket, filters, error mask,
// CAN FD, receive buffer, timestamps, drop counter, bind.
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

#include "can_logger.h"
#include "ndsid/can/socketcan_source.h"

namespace ndsid::can {

int OpenCanSocket(const SocketCanOptions& options, std::string& error) noexcept {
  int fd = -1;
  int saved_errno = 0;
  try {
    auto fail = [&](const std::string& step) {
      saved_errno = errno;
      error = step + ": " + std::strerror(saved_errno);
      if (fd >= 0) close(fd);
      errno = saved_errno;
      return -1;
    };
    if (options.interface.empty() || options.interface.size() >= IFNAMSIZ) {
      errno = EINVAL;
      return fail("interface name must have 1 to 15 characters");
    }
    fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
    if (fd < 0) return fail("socket(PF_CAN, SOCK_RAW, CAN_RAW)");
    const unsigned index = if_nametoindex(options.interface.c_str());
    if (index == 0) return fail("no interface named " + options.interface);
    // A socket bound to an interface that is down reports ENETDOWN at once: fail here instead,
    // so that reopening backs off until the interface is up (no reconnect storm).
    ifreq request{};
    std::memcpy(request.ifr_name, options.interface.c_str(), options.interface.size());
    if (ioctl(fd, SIOCGIFFLAGS, &request) == 0 && (request.ifr_flags & IFF_UP) == 0) {
      errno = ENETDOWN;
      return fail(options.interface + " is down");
    }

    if (!options.ids.empty() && options.ids.size() <= CAN_RAW_FILTER_MAX) {
      std::vector<can_filter> filters;
      filters.reserve(options.ids.size());
      for (const auto& f : options.ids) {  // data frames only: RTR is in the mask, not the id
        filters.push_back(f.extended
                              ? can_filter{f.id | CAN_EFF_FLAG, CAN_EFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG}
                              : can_filter{f.id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
      }
      if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                     static_cast<socklen_t>(filters.size() * sizeof(can_filter))) != 0) {
        return fail("setsockopt(CAN_RAW_FILTER)");
      }
    }
    const can_err_mask_t error_mask = options.error_mask & CAN_ERR_MASK;
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof error_mask) != 0) {
      return fail("setsockopt(CAN_RAW_ERR_FILTER)");
    }
    const int one = 1;
    if (options.fd_frames &&
        setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &one, sizeof one) != 0) {
      CanLogger()->warn("socketcan {}: CAN FD frames not supported by this kernel: {}",
                        options.interface, std::strerror(errno));
    }
    if (options.receive_buffer_bytes > 0) {
      const int bytes = options.receive_buffer_bytes;
      if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) != 0 &&
          setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes) != 0) {
        return fail("setsockopt(SO_RCVBUF)");
      }
    }
    if (setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) != 0) {
      return fail("setsockopt(SO_TIMESTAMPNS)");
    }
    if (setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one) != 0) {
      CanLogger()->warn("socketcan {}: no drop counter (SO_RXQ_OVFL): {}", options.interface,
                        std::strerror(errno));
    }
    sockaddr_can address{};
    address.can_family = AF_CAN;
    address.can_ifindex = static_cast<int>(index);
    if (bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      return fail("bind to " + options.interface);
    }
    return fd;
  } catch (...) {
    if (fd >= 0) close(fd);
    errno = ENOMEM;
    return -1;
  }
}

}  // namespace ndsid::can
