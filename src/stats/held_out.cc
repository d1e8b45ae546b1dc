#include "ndsid/stats/held_out.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace ndsid::stats {

std::set<int64_t> HeldOutDrives(const std::deque<std::shared_ptr<const Segment>>& window, double validation_fraction) {
  std::set<int64_t> out;
  if (!(validation_fraction > 0)) return out;
  const int64_t every = std::max<int64_t>(2, std::llround(1.0 / validation_fraction));
  std::map<int64_t, double> drive_s;
  for (const auto& seg : window) drive_s[seg->drive_id] += seg->duration_s();
  for (const auto& [d, s] : drive_s)
    if (d % every == every - 1) out.insert(d);
  if (out.empty() && drive_s.size() >= 2) {
    out.insert(std::min_element(drive_s.begin(), drive_s.end(), [](const auto& a, const auto& b) { return a.second < b.second; })->first);
  }
  return out;
}

}  // namespace ndsid::stats
