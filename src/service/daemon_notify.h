// systemd notification for ndsidd via libsystemd's sd_notify (only ndsidd links libsystemd,
// with NDSID_HAVE_SYSTEMD); without it, or outside systemd (no NOTIFY_SOCKET), a no-op.
// Thread: the reading thread sends every notification.
#pragma once

#include <cstdint>

#include "daemon.h"

#ifdef NDSID_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace ndsid::service {

inline ServiceNotifier SystemdNotifier() {
  ServiceNotifier n;
#ifdef NDSID_HAVE_SYSTEMD
  n.notify = [](const std::string& state) { sd_notify(0, state.c_str()); };
  uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) n.watchdog_usec = usec;
#endif
  return n;
}

}  // namespace ndsid::service
