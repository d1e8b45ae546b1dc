// A one-line progress display for long desk commands: share done, frame rate, data hours per
// second and the time left, redrawn in place on stderr at most twice a second. Shown only when
// stderr is a terminal (quiet in pipes, logs and CI), or when NDSID_PROGRESS=1; NDSID_PROGRESS=0
// turns it off.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace ndsid::desk {

// "replay   43 %   1.25 M frames/s   0.85 data-h/s   ETA 0:12" (fraction < 0: no % and ETA).
std::string FormatProgressLine(const std::string& what, double fraction, uint64_t frames, double data_s,
                               double elapsed_s);

class Progress {
 public:
  explicit Progress(std::string what);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // fraction: 0..1 of the work (< 0 unknown); frames and data seconds processed so far.
  void Update(double fraction, uint64_t frames, double data_s);
  // Clears the line (also done by the destructor).
  void Done();
  bool enabled() const { return enabled_; }

 private:
  std::string what_;
  bool enabled_ = false;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace ndsid::desk
