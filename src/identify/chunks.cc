#include "chunks.h"

#include <cmath>

namespace ndsid::identify {

size_t BurnInSamples(const Chunk& c, double burn_in_s) {
  return static_cast<size_t>(std::ceil(burn_in_s / c.dt_s));
}

std::vector<Chunk> MakeChunks(const SegmentList& segments, double chunk_s, double burn_in_s) {
  std::vector<Chunk> chunks;
  for (const stats::Segment* seg : segments) {
    if (seg == nullptr || seg->samples.empty()) continue;
    const size_t per = std::max<size_t>(1, static_cast<size_t>(std::lround(chunk_s / seg->dt_s)));
    const size_t total = seg->samples.size();
    size_t start = 0;
    while (start < total) {
      size_t n = std::min(per, total - start);
      if (total - (start + n) < per / 2) n = total - start;  // fold a short tail into this chunk
      Chunk c{seg->samples.data() + start, n, seg->dt_s, seg->drive_id};
      if (n > BurnInSamples(c, burn_in_s) + 1) chunks.push_back(c);
      start += n;
    }
  }
  return chunks;
}

}  // namespace ndsid::identify
