// The model's output sample by sample, simulated exactly as the fit scores it (the same
// chunks, burn-in and road-bank estimate as Identifier::Rmse): for comparison reports and
// residual analysis outside the identify stage.
#pragma once

#include <cstddef>
#include <vector>

#include "ndsid/identify/identifier.h"

namespace ndsid::identify {

struct ChunkOutput {
  const stats::Segment* segment = nullptr;
  size_t segment_index = 0;  // position of the segment in the list passed in
  size_t first = 0;          // index of the chunk's first sample in segment->samples
  size_t n = 0;
  size_t burn_in = 0;        // leading samples the fit does not score (unknown initial state)
  std::vector<double> a_y_model_mps2;       // modelled measured a_y
  std::vector<double> yaw_rate_model_radps;  // modelled measured yaw rate (r + gyro_offset, gyro_scale terms)
};

// params: full vector of identifier.spec() (base six, then effect parameters).
std::vector<ChunkOutput> SimulateChunks(const Identifier& identifier, const std::vector<double>& params,
                                        const SegmentList& segments);

}  // namespace ndsid::identify
