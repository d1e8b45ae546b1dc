#include "progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace ndsid::desk {

std::string FormatProgressLine(const std::string& what, double fraction, uint64_t frames, double data_s,
                               double elapsed_s) {
  char buf[160];
  const double t = elapsed_s > 1e-9 ? elapsed_s : 1e-9;
  int n = std::snprintf(buf, sizeof buf, "%-8s", what.c_str());
  if (fraction >= 0) n += std::snprintf(buf + n, sizeof buf - n, " %3.0f %%", 100.0 * std::fmin(fraction, 1.0));
  n += std::snprintf(buf + n, sizeof buf - n, "   %.2f M frames/s   %.2f data-h/s", frames / t / 1e6, data_s / 3600.0 / t);
  if (fraction > 0.005 && fraction < 1) {
    const double left = elapsed_s * (1 - fraction) / fraction;
    const long s = std::lround(left);
    n += std::snprintf(buf + n, sizeof buf - n, "   ETA %ld:%02ld", s / 60, s % 60);
  }
  return std::string(buf, static_cast<size_t>(n < 0 ? 0 : n));
}

Progress::Progress(std::string what) : what_(std::move(what)) {
  const char* env = std::getenv("NDSID_PROGRESS");
  enabled_ = env ? std::strcmp(env, "0") != 0 : ::isatty(STDERR_FILENO) == 1;
  start_ = std::chrono::steady_clock::now();
  last_ = start_ - std::chrono::seconds(1);  // the first update is shown at once
}

Progress::~Progress() { Done(); }

void Progress::Update(double fraction, uint64_t frames, double data_s) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_ < std::chrono::milliseconds(500)) return;
  last_ = now;
  const std::string line =
      FormatProgressLine(what_, fraction, frames, data_s, std::chrono::duration<double>(now - start_).count());
  std::fprintf(stderr, "\r%-79s", line.c_str());
  std::fflush(stderr);
  shown_ = true;
}

void Progress::Done() {
  if (!shown_) return;
  std::fprintf(stderr, "\r%79s\r", "");
  std::fflush(stderr);
  shown_ = false;
}

}  // namespace ndsid::desk
