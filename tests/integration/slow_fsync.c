/* LD_PRELOAD shim for daemon_test.py (SlowFsyncDoesNotStallReading): every fsync() sleeps
 * NDSID_SLOW_FSYNC_S seconds first, as on a slow SD card or a congested eMMC. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>
#include <time.h>

int fsync(int fd) {
  static int (*real_fsync)(int) = 0;
  if (!real_fsync) real_fsync = (int (*)(int))dlsym(RTLD_NEXT, "fsync");
  const char* s = getenv("NDSID_SLOW_FSYNC_S");
  if (s) {
    const double d = atof(s);
    if (d > 0) {
      struct timespec ts;
      ts.tv_sec = (time_t)d;
      ts.tv_nsec = (long)((d - (double)ts.tv_sec) * 1e9);
      nanosleep(&ts, 0);
    }
  }
  return real_fsync(fd);
}
