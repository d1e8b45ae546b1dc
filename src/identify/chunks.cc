#include "chunks.h"

#include <cmath>

namespace ndsid::identify {

size_t BurnInSamples(const Chunk& c, double burn_in_s) {
  return static_cast<size_t>(std::ceil(burn_in_s / c.dt_s));
}

std::vector<float> EstimateBank(const stats::Segment& seg, double tau_s) {
  std::vector<float> g;
  if (!seg.has_yaw_rate || seg.samples.empty()) return g;
  const size_t n = seg.samples.size();
  std::vector<double> x(n);
  for (size_t k = 0; k < n; ++k) {
    const auto& s = seg.samples[k];
    x[k] = static_cast<double>(s.speed_mps) * s.yaw_rate_radps - s.lat_accel_mps2;
  }
  const double a = seg.dt_s / (tau_s + seg.dt_s);
  for (size_t k = 1; k < n; ++k) x[k] = x[k - 1] + a * (x[k] - x[k - 1]);
  for (size_t k = n - 1; k-- > 0;) x[k] = x[k + 1] + a * (x[k] - x[k + 1]);
  g.assign(x.begin(), x.end());
  return g;
}

std::vector<Chunk> MakeChunks(const SegmentList& segments, double chunk_s, double burn_in_s) {
  std::vector<Chunk> chunks;
  for (const stats::Segment* seg : segments) {
    if (seg == nullptr || seg->samples.empty()) continue;
    const auto bank = std::make_shared<const std::vector<float>>(EstimateBank(*seg));
    const size_t per = std::max<size_t>(1, static_cast<size_t>(std::lround(chunk_s / seg->dt_s)));
    const size_t total = seg->samples.size();
    size_t start = 0;
    while (start < total) {
      size_t n = std::min(per, total - start);
      if (total - (start + n) < per / 2) n = total - start;  // fold a short tail into this chunk
      Chunk c{seg->samples.data() + start, n, seg->dt_s, seg->drive_id, nullptr};
      if (!bank->empty()) {
        c.bank = std::make_shared<const std::vector<float>>(bank->begin() + static_cast<long>(start),
                                                            bank->begin() + static_cast<long>(start + n));
      }
      if (n > BurnInSamples(c, burn_in_s) + 1) chunks.push_back(c);
      start += n;
    }
  }
  return chunks;
}

}  // namespace ndsid::identify
