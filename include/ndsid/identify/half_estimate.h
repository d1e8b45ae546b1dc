// EG of one half of the window (alternate training drives; with one drive, its earlier or later
// gated time), fitted from the whole window's
// estimate (src/identify/half_estimates.h): what the checks of the fit compare and what widens
// the published sigma(EG) when the halves disagree.
#pragma once

#include <cstddef>
#include <string>

namespace ndsid::identify {

// The fewest chunks a cluster-robust sigma is computed over (the whole window's, a half's), and
// so the fewest each half of a single drive split in time needs (optimum_sums.cc).
inline constexpr size_t kClusterRobustMinChunks = 10;

struct HalfEstimate {
  bool valid = false;
  std::string reason;  // why not valid
  double eg_rad_per_mps2 = 0, eg_se_rad_per_mps2 = 0;
  int drives = 0;
  size_t chunks = 0;
  bool in_time = false;  // a single drive's earlier or later gated time (else alternate drives)
};

}  // namespace ndsid::identify
