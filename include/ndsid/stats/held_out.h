// Which drives of the window are held out for validation (the held-out RMSE): every k-th drive
// (drive_id % k == k - 1, k = max(2, round(1 / validation_fraction))); while the window holds none
// of those, the shortest drive once there are two, so that a validation RMSE exists whenever two
// drives do. The pipeline's snapshots and the update benchmark use this one rule.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <set>

#include "ndsid/stats/segment.h"

namespace ndsid::stats {

// validation_fraction <= 0: none. O(segments + drives log drives).
std::set<int64_t> HeldOutDrives(const std::deque<std::shared_ptr<const Segment>>& window, double validation_fraction);

}  // namespace ndsid::stats
